// GPIO on a real kernel chip through libgpiod: the contract plus the device classes on a real line. Runs only
// when QSG_GPIO_CHIP (e.g. /dev/gpiochip0, the qemu virt board's PL061 with 8 lines) and QSG_GPIO_LINE are set.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "drivers/gpio/gpio_devices.h"
#include "tests/drivers/gpio/gpio_real_case.h"

namespace qsg::testing {

INSTANTIATE_TEST_SUITE_P(Hardware, GpioLineContract,
                         ::testing::Values(GpioContractCase{"libgpiod", make_real_gpio_chip}),
                         gpio_contract_case_name);

namespace {

TEST(GpioHardware, HeartbeatAndTriggerDriveARealLine) {
  unsigned offset = 0;
  std::string reason;
  std::unique_ptr<gpio::GpioChip> chip = make_real_gpio_chip(&offset, &reason);
  if (!chip) GTEST_SKIP() << reason;
  gpio::GpioLineRequest r;
  r.offset = offset;
  r.direction = gpio::GpioDirection::kOutput;
  r.consumer = "qsg-hw-test";
  std::string error;
  auto line = chip->request(r, &error);
  ASSERT_TRUE(line) << error;
  gpio::Heartbeat heartbeat(*line);
  bool high = false;
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(heartbeat.toggle()) << line->last_error();
    ASSERT_TRUE(line->get(&high)) << line->last_error();
    EXPECT_EQ(high, heartbeat.level());
  }
  gpio::TriggerPulse trigger(*line, gpio::TriggerPulse::Config{1'000});
  if (heartbeat.level()) heartbeat.toggle();
  ASSERT_TRUE(trigger.fire(0));
  ASSERT_TRUE(line->get(&high));
  EXPECT_TRUE(high);
  ASSERT_TRUE(trigger.update(1'000));
  ASSERT_TRUE(line->get(&high));
  EXPECT_FALSE(high);
  std::printf("%s: %llu writes, %llu reads, %llu errors\n", line->name(),
              static_cast<unsigned long long>(line->counters().writes),
              static_cast<unsigned long long>(line->counters().reads),
              static_cast<unsigned long long>(line->counters().errors));
}

TEST(GpioHardware, AMissingChipIsAClearError) {
  std::string error;
  EXPECT_FALSE(gpio::GpiodChip::open("/dev/qsg-no-such-gpiochip", &error));
  EXPECT_NE(error.find("qsg-no-such-gpiochip"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::testing
