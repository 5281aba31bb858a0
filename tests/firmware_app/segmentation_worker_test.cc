// SegmentationWorker with the real ESPNetv2 network (skips without ../shared/data): keyframes are taken only when
// the worker is idle and the interval has passed, the labels that come back are the segmenter's own for that
// frame, late labels are dropped and counted, and taking a frame allocates nothing.
#include "firmware_app/segmentation_worker.h"

#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "tests/support/allocation_counter.h"
#include "tests/support/emulation.h"
#include "tests/support/test_data.h"

namespace qsg::app {
namespace {

constexpr const char* kModel = "models/espnetv2_s2_pascal384.onnx";
constexpr const char* kTumColor = "rgbd/redwood_open3d/RGBD/other_formats/TUM_color.png";

std::unique_ptr<segmentation::Segmenter> make_segmenter(const std::string& model, std::string* error) {
  segmentation::LabelMap map;
  if (!map.load(std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json", error))
    return nullptr;
  segmentation::Config c;
  c.model_path = model;
  auto seg = std::make_unique<segmentation::Segmenter>();
  if (!seg->init(c, map, error)) return nullptr;
  return seg;
}

std::unique_ptr<drivers::RgbdFrame> tum_frame(const std::string& path, std::int64_t t_ns) {
  const cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
  if (bgr.empty()) return nullptr;
  auto f = std::make_unique<drivers::RgbdFrame>();
  f->intrinsics = {bgr.cols, bgr.rows, 525.0, 525.0, 319.5, 239.5};
  cv::Mat rgb(bgr.rows, bgr.cols, CV_8UC3, f->rgb.data());
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  for (int i = 0; i < f->pixels(); ++i) f->depth_m[static_cast<std::size_t>(i)] = 1.0f + 0.001f * (i % 100);
  f->sample_time_ns = t_ns;
  f->sequence = static_cast<std::uint64_t>(t_ns / 1000000);
  return f;
}

class SegmentationWorkerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    QSG_REQUIRE_SHARED_DATA(model, kModel);
    QSG_REQUIRE_SHARED_DATA(color, kTumColor);
    if (::qsg::testing::running_emulated()) GTEST_SKIP() << "the real network under qemu-user is too slow";
    model_ = model;
    frame_ = tum_frame(color, 1000000000);
    ASSERT_NE(frame_, nullptr) << color;
    // What the segmenter itself makes of the frame.
    std::string error;
    auto seg = make_segmenter(model_, &error);
    ASSERT_NE(seg, nullptr) << error;
    reference_ = std::make_unique<drivers::RgbdFrame>(*frame_);
    ASSERT_TRUE(seg->segment(*reference_, &error)) << error;
  }
  std::string model_;
  std::unique_ptr<drivers::RgbdFrame> frame_, reference_;
};

TEST_F(SegmentationWorkerTest, LockstepTakesWhenIdleAndReturnsTheFramesOwnLabels) {
  std::string error;
  SegmentationWorker w;
  SegmentationWorkerConfig c;
  c.threaded = false;
  c.min_interval_s = 0.5;
  c.max_age_s = 2.0;
  c.budget_us = 1;  // every run overruns a 1 us budget: the overrun is counted
  ASSERT_TRUE(w.init(make_segmenter(model_, &error), 2, c, &error)) << error;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(1.0, 2.0, 3.0);
  bool taken = false;
  EXPECT_NO_ALLOCATIONS(taken = w.offer(*frame_, pose));
  EXPECT_TRUE(taken);
  EXPECT_FALSE(w.idle());
  frame_->sample_time_ns += 1000000000;  // a second later, but the worker has not run: busy
  EXPECT_FALSE(w.offer(*frame_, pose));
  EXPECT_EQ(w.labelled(frame_->sample_time_ns), nullptr) << "nothing is labelled before the worker ran";
  w.run_pending();
  EXPECT_TRUE(w.idle());
  const SegmentationWorker::Slot* slot = w.labelled(frame_->sample_time_ns);
  ASSERT_NE(slot, nullptr);
  EXPECT_TRUE(slot->frame->has_labels);
  EXPECT_EQ(slot->frame->sample_time_ns, 1000000000);
  EXPECT_TRUE(slot->world_T_camera.isApprox(pose));
  const int n = frame_->pixels();
  EXPECT_TRUE(std::equal(slot->frame->labels.begin(), slot->frame->labels.begin() + n, reference_->labels.begin()));
  EXPECT_TRUE(std::equal(slot->frame->depth_m.begin(), slot->frame->depth_m.begin() + n, frame_->depth_m.begin()));
  w.release(slot);
  EXPECT_EQ(w.labelled(frame_->sample_time_ns), nullptr);
  // Too soon after the last frame taken (0.5 s asked): skipped; then taken again.
  frame_->sample_time_ns = 1000000000 + 300000000;
  EXPECT_FALSE(w.offer(*frame_, pose));
  frame_->sample_time_ns = 1000000000 + 600000000;
  EXPECT_TRUE(w.offer(*frame_, pose));
  w.run_pending();
  // Collected 2.5 s after its frame: older than max_age_s, dropped and counted.
  EXPECT_EQ(w.labelled(frame_->sample_time_ns + 2500000000), nullptr);
  const SegmentationWorkerCounters k = w.counters();
  EXPECT_EQ(k.offered, 4u);
  EXPECT_EQ(k.taken, 2u);
  EXPECT_EQ(k.busy, 1u);
  EXPECT_EQ(k.too_soon, 1u);
  EXPECT_EQ(k.labelled, 2u);
  EXPECT_EQ(k.collected, 1u);
  EXPECT_EQ(k.stale, 1u);
  EXPECT_EQ(w.cpu_stats().runs, 2u);
  EXPECT_EQ(w.cpu_stats().overruns, 2u);
  EXPECT_GT(w.cpu_stats().min_us, 0);
  EXPECT_EQ(w.wall_stats().runs, 2u);
  EXPECT_LE(w.slots_high_water(), 2u);
}

TEST_F(SegmentationWorkerTest, ThreadedWorkerLabelsBesideTheCaller) {
  std::string error;
  SegmentationWorker w;
  SegmentationWorkerConfig c;
  ASSERT_TRUE(w.init(make_segmenter(model_, &error), 2, c, &error)) << error;
  ASSERT_TRUE(w.offer(*frame_, Eigen::Isometry3d::Identity()));
  const SegmentationWorker::Slot* slot = nullptr;
  for (int i = 0; i < 6000 && slot == nullptr; ++i) {  // up to a minute on a loaded machine
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    slot = w.labelled(frame_->sample_time_ns);
  }
  ASSERT_NE(slot, nullptr) << "the worker thread never labelled the frame";
  EXPECT_TRUE(std::equal(slot->frame->labels.begin(), slot->frame->labels.begin() + frame_->pixels(),
                         reference_->labels.begin()));
  w.release(slot);
  w.stop();
  EXPECT_EQ(w.counters().collected, 1u);
  EXPECT_EQ(w.cpu_stats().runs, 1u);
}

TEST(SegmentationWorkerSetupTest, RefusesAMissingSegmenterOrTooFewSlots) {
  SegmentationWorker w;
  std::string error;
  EXPECT_FALSE(w.init(nullptr, 2, SegmentationWorkerConfig{}, &error));
  EXPECT_NE(error.find("not initialised"), std::string::npos) << error;
  EXPECT_FALSE(w.initialized());
  auto frame = std::make_unique<drivers::RgbdFrame>();
  EXPECT_FALSE(w.offer(*frame, Eigen::Isometry3d::Identity()));
  EXPECT_EQ(w.labelled(0), nullptr);
}

}  // namespace
}  // namespace qsg::app
