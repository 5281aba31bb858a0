// Behavioural contract every drivers::RgbdSource backend must pass (replays, simulated camera, fault decorator,
// hardware). Include this header in exactly one .cc of a test binary and instantiate it there, inside the
// namespace (gtest pastes the suite name into identifiers, so it cannot be qualified):
//
//   namespace qsg::testing {
//   INSTANTIATE_TEST_SUITE_P(MyBackend, RgbdSourceContract,
//                            ::testing::Values(RgbdContractCase{"my_backend", make_my_backend}),
//                            rgbd_contract_case_name);
//   }
//
// where make_my_backend(std::string* skip_reason) returns a fresh source (std::shared_ptr; use the aliasing
// constructor to keep whatever the source refers to alive), or nullptr with a reason to skip the case.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <ostream>
#include <string>

#include "drivers/sources.h"
#include "tests/support/allocation_counter.h"

namespace qsg::testing {

struct RgbdContractCase {
  std::string name;  // test-name suffix: letters, digits and '_'
  std::function<std::shared_ptr<drivers::RgbdSource>(std::string* skip_reason)> make;
  bool finite = true;           // reaches kEndOfStream within max_reads (replays); false for endless sources
  int max_reads = 400;          // reads attempted per test
  bool reads_allocate = false;  // replays decode with OpenCV (allocates); simulated sources must not
};

// gtest prints parameters in test listings; the name is all a reader needs.
inline void PrintTo(const RgbdContractCase& c, std::ostream* os) { *os << c.name; }

inline std::string rgbd_contract_case_name(const ::testing::TestParamInfo<RgbdContractCase>& info) {
  return info.param.name;
}

class RgbdSourceContract : public ::testing::TestWithParam<RgbdContractCase> {
 protected:
  static constexpr std::uint32_t kKnownFlags = messages::kFrameLate | messages::kFrameTimestampBackwards |
                                               messages::kFrameInvalidDepthRegion | messages::kFrameSequenceGap |
                                               messages::kFrameAfterReconnect;

  void SetUp() override {
    std::string reason;
    source_ = GetParam().make(&reason);
    if (!source_) GTEST_SKIP() << "backend '" << GetParam().name << "' unavailable: " << reason;
    frame_ = std::make_unique<messages::RgbdFrame>();
  }

  // Checks one delivered frame against the source and the previous frame; returns sequence numbers skipped.
  std::uint64_t check_frame(const messages::RgbdFrame& f, bool* have_prev, std::uint64_t* prev_sequence) {
    const messages::CameraIntrinsics k = source_->intrinsics();
    EXPECT_TRUE(f.intrinsics.valid());
    EXPECT_EQ(f.width(), k.width);
    EXPECT_EQ(f.height(), k.height);
    EXPECT_EQ(f.intrinsics.fx, k.fx);
    EXPECT_EQ(f.intrinsics.fy, k.fy);
    EXPECT_LE(f.sample_time_ns, f.publish_time_ns) << "sequence " << f.sequence;
    EXPECT_GT(f.depth_scale_m, 0.0f);
    EXPECT_EQ(f.flags & ~kKnownFlags, 0u) << "unknown flag bits";
    int negative = 0;
    for (int i = 0; i < f.pixels(); ++i) negative += f.depth_m[i] < 0.0f ? 1 : 0;  // NaN compares false
    EXPECT_EQ(negative, 0) << "negative depth in frame " << f.sequence;
    std::uint64_t skipped = 0;
    if (*have_prev) {
      EXPECT_GT(f.sequence, *prev_sequence) << "sequence numbers must strictly increase";
      if (f.sequence > *prev_sequence + 1) {
        skipped = f.sequence - *prev_sequence - 1;
        EXPECT_TRUE(f.flags & messages::kFrameSequenceGap)
            << "sequence jumped from " << *prev_sequence << " to " << f.sequence << " without kFrameSequenceGap";
      }
    }
    *have_prev = true;
    *prev_sequence = f.sequence;
    return skipped;
  }

  std::shared_ptr<drivers::RgbdSource> source_;
  std::unique_ptr<messages::RgbdFrame> frame_;
};

TEST_P(RgbdSourceContract, IntrinsicsAreValid) {
  EXPECT_TRUE(source_->intrinsics().valid());
  EXPECT_NE(source_->name(), nullptr);
}

TEST_P(RgbdSourceContract, DeliveredFramesKeepTheInvariants) {
  bool have_prev = false;
  std::uint64_t prev = 0;
  std::uint64_t ok = 0;
  std::uint64_t skipped = 0;
  bool ended = false;
  for (int i = 0; i < GetParam().max_reads && !ended; ++i) {
    const drivers::ReadStatus s = source_->read(*frame_, 100'000'000);
    switch (s) {
      case drivers::ReadStatus::kOk:
        ++ok;
        skipped += check_frame(*frame_, &have_prev, &prev);
        break;
      case drivers::ReadStatus::kEndOfStream: ended = true; break;
      case drivers::ReadStatus::kTimeout:
      case drivers::ReadStatus::kDisconnected:
      case drivers::ReadStatus::kBadFrame: break;
      default: ADD_FAILURE() << "read returned an unknown status " << static_cast<int>(s);
    }
  }
  if (GetParam().finite) {
    EXPECT_TRUE(ended) << "no kEndOfStream within " << GetParam().max_reads << " reads";
  }
  EXPECT_GT(ok, 0u) << "no frame delivered";
  const drivers::DriverCounters& c = source_->counters();
  EXPECT_EQ(c.delivered, ok);
  EXPECT_GE(c.dropped + c.bad_frames + c.missing_files, skipped)
      << "every skipped sequence number must be counted as dropped, bad or missing";
}

TEST_P(RgbdSourceContract, EndOfStreamIsSticky) {
  if (!GetParam().finite) GTEST_SKIP() << "endless source";
  int i = 0;
  while (i < GetParam().max_reads && source_->read(*frame_, 0) != drivers::ReadStatus::kEndOfStream) ++i;
  ASSERT_LT(i, GetParam().max_reads) << "no kEndOfStream";
  const std::uint64_t delivered = source_->counters().delivered;
  for (int k = 0; k < 5; ++k) EXPECT_EQ(source_->read(*frame_, 1'000'000), drivers::ReadStatus::kEndOfStream);
  EXPECT_EQ(source_->counters().delivered, delivered);
}

TEST_P(RgbdSourceContract, ZeroTimeoutNeverCrashes) {
  bool have_prev = false;
  std::uint64_t prev = 0;
  for (int i = 0; i < GetParam().max_reads; ++i) {
    const drivers::ReadStatus s = source_->read(*frame_, 0);
    if (s == drivers::ReadStatus::kOk) check_frame(*frame_, &have_prev, &prev);
    if (s == drivers::ReadStatus::kEndOfStream) break;
  }
}

TEST_P(RgbdSourceContract, SteadyStateReadsDoNotAllocate) {
  if (GetParam().reads_allocate) GTEST_SKIP() << "this backend decodes files with OpenCV, which allocates";
  source_->read(*frame_, 0);  // warm-up: lazy first-read set-up is allowed
  EXPECT_NO_ALLOCATIONS(for (int i = 0; i < 20; ++i) source_->read(*frame_, 0));
}

}  // namespace qsg::testing
