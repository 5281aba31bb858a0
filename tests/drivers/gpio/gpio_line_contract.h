// Behavioural contract every gpio::GpioChip backend must pass (simulated, libgpiod). Include in one .cc of a test
// binary and instantiate inside namespace qsg::testing:
//
//   INSTANTIATE_TEST_SUITE_P(MyBackend, GpioLineContract,
//                            ::testing::Values(GpioContractCase{"my_backend", make_my_chip}), gpio_contract_case_name);
//
// where make_my_chip(unsigned* offset, std::string* skip_reason) returns a fresh chip and the offset of a line the
// suite may request as output and input, or nullptr with a reason to skip.
#pragma once

#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <ostream>
#include <string>

#include "drivers/gpio/gpio_line.h"
#include "tests/support/allocation_counter.h"

namespace qsg::testing {

struct GpioContractCase {
  std::string name;  // letters, digits and '_'
  std::function<std::unique_ptr<gpio::GpioChip>(unsigned* offset, std::string* skip_reason)> make;
};

inline void PrintTo(const GpioContractCase& c, std::ostream* os) { *os << c.name; }
inline std::string gpio_contract_case_name(const ::testing::TestParamInfo<GpioContractCase>& info) {
  return info.param.name;
}

class GpioLineContract : public ::testing::TestWithParam<GpioContractCase> {
 protected:
  void SetUp() override {
    std::string reason;
    chip_ = GetParam().make(&offset_, &reason);
    if (!chip_) GTEST_SKIP() << "GPIO backend '" << GetParam().name << "' unavailable: " << reason;
  }
  std::unique_ptr<gpio::GpioLine> request(gpio::GpioDirection direction, bool initial_high, std::string* error) {
    gpio::GpioLineRequest r;
    r.offset = offset_;
    r.direction = direction;
    r.initial_high = initial_high;
    r.consumer = "qsg-contract";
    return chip_->request(r, error);
  }
  static bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

  std::unique_ptr<gpio::GpioChip> chip_;
  unsigned offset_ = 0;
};

TEST_P(GpioLineContract, ChipDescribesItself) {
  ASSERT_NE(chip_->name(), nullptr);
  EXPECT_GT(std::string(chip_->name()).size(), 0u);
  EXPECT_LT(offset_, chip_->num_lines());
}

TEST_P(GpioLineContract, OutputIsDrivenAndReadBack) {
  std::string error;
  auto line = request(gpio::GpioDirection::kOutput, false, &error);
  ASSERT_TRUE(line) << error;
  EXPECT_EQ(line->direction(), gpio::GpioDirection::kOutput);
  EXPECT_TRUE(contains(line->name(), std::to_string(offset_))) << line->name();
  bool high = true;
  ASSERT_TRUE(line->get(&high)) << line->last_error();
  EXPECT_FALSE(high) << "requested low";
  ASSERT_TRUE(line->set(true)) << line->last_error();
  ASSERT_TRUE(line->get(&high)) << line->last_error();
  EXPECT_TRUE(high);
  ASSERT_TRUE(line->set(false)) << line->last_error();
  ASSERT_TRUE(line->get(&high)) << line->last_error();
  EXPECT_FALSE(high);
  EXPECT_EQ(line->counters().writes, 2u);
  EXPECT_EQ(line->counters().reads, 3u);
  EXPECT_EQ(line->counters().errors, 0u);
}

TEST_P(GpioLineContract, InitialHighIsDrivenFromTheRequest) {
  std::string error;
  auto line = request(gpio::GpioDirection::kOutput, true, &error);
  ASSERT_TRUE(line) << error;
  bool high = false;
  ASSERT_TRUE(line->get(&high)) << line->last_error();
  EXPECT_TRUE(high);
}

TEST_P(GpioLineContract, ASecondRequestOfTheSameLineIsBusy) {
  std::string error;
  auto first = request(gpio::GpioDirection::kOutput, false, &error);
  ASSERT_TRUE(first) << error;
  auto second = request(gpio::GpioDirection::kInput, false, &error);
  EXPECT_FALSE(second);
  EXPECT_TRUE(contains(error, "busy")) << error;
  EXPECT_TRUE(contains(error, chip_->name()) && contains(error, std::to_string(offset_))) << error;
  first.reset();
  auto third = request(gpio::GpioDirection::kOutput, false, &error);
  EXPECT_TRUE(third) << "a released line can be requested again: " << error;
}

TEST_P(GpioLineContract, AnOffsetOutOfRangeIsAClearError) {
  gpio::GpioLineRequest r;
  r.offset = chip_->num_lines();
  r.direction = gpio::GpioDirection::kOutput;
  std::string error;
  EXPECT_FALSE(chip_->request(r, &error));
  EXPECT_TRUE(contains(error, "out of range") && contains(error, std::to_string(chip_->num_lines()))) << error;
}

TEST_P(GpioLineContract, InputIsReadAndRefusesToBeDriven) {
  std::string error;
  auto line = request(gpio::GpioDirection::kInput, false, &error);
  ASSERT_TRUE(line) << error;
  EXPECT_EQ(line->direction(), gpio::GpioDirection::kInput);
  bool high = false;
  EXPECT_TRUE(line->get(&high)) << line->last_error();
  EXPECT_FALSE(line->set(true));
  EXPECT_TRUE(contains(line->last_error(), "input")) << line->last_error();
  EXPECT_EQ(line->counters().errors, 1u);
}

TEST_P(GpioLineContract, SetAndGetDoNotAllocate) {
  std::string error;
  auto line = request(gpio::GpioDirection::kOutput, false, &error);
  ASSERT_TRUE(line) << error;
  bool high = false;
  int failures = 0;
  EXPECT_NO_ALLOCATIONS(for (int i = 0; i < 50; ++i) {
    failures += line->set((i & 1) != 0) ? 0 : 1;
    failures += line->get(&high) ? 0 : 1;
  });
  EXPECT_EQ(failures, 0);
}

}  // namespace qsg::testing
