// SegmentationWorker with the real ESPNetv2 network (skips without ../shared/data): keyframes are taken only when
// the worker is idle and the interval has passed, the labels that come back are the segmenter's own for that
// frame, late labels are dropped and counted, and taking a frame allocates nothing.
#include "firmware_app/segmentation_worker.h"

#include "firmware_app/pipeline.h"

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

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

std::unique_ptr<messages::RgbdFrame> tum_frame(const std::string& path, std::int64_t t_ns) {
  const cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
  if (bgr.empty()) return nullptr;
  auto f = std::make_unique<messages::RgbdFrame>();
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
    reference_ = std::make_unique<messages::RgbdFrame>(*frame_);
    ASSERT_TRUE(seg->segment(*reference_, &error)) << error;
  }
  std::string model_;
  std::unique_ptr<messages::RgbdFrame> frame_, reference_;
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
  // Woken by the worker when its run ends (the bound only keeps a broken worker from hanging the suite).
  ASSERT_TRUE(w.wait_until_idle(std::chrono::minutes(1))) << "the worker thread never finished the frame";
  const SegmentationWorker::Slot* slot = w.labelled(frame_->sample_time_ns);
  ASSERT_NE(slot, nullptr) << "the worker thread never labelled the frame";
  EXPECT_TRUE(std::equal(slot->frame->labels.begin(), slot->frame->labels.begin() + frame_->pixels(),
                         reference_->labels.begin()));
  w.release(slot);
  w.stop();
  EXPECT_EQ(w.counters().collected, 1u);
  EXPECT_EQ(w.cpu_stats().runs, 1u);
}

// The app with the network on (lockstep, ground-truth labels off): every keyframe is integrated at once, the worker
// labels the keyframes it takes, and their votes reach the map; with min_interval_s only some are taken, and the
// others are counted as unlabelled. The config's backend reaches the segmenter.
AppConfig segmenting_config(const std::string& name, const std::string& model) {
  AppConfig c;
  c.output_dir = ::testing::TempDir() + "/qsg_segmentation_" + name;
  c.building.num_rooms = 4;
  c.building.seed = 3;
  c.camera.intrinsics = {160, 120, 131.25, 131.25, 79.5, 59.5};
  c.snapshot_interval_s = 1e6;
  c.telemetry_interval_s = 1e6;
  c.ground_truth_labels = false;
  c.segmentation.model_path = model;
  c.segmentation.label_map_path = std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json";
  return c;
}

TEST_F(SegmentationWorkerTest, PipelineVotesTheLabelsOfTheKeyframesTheWorkerTook) {
  for (const double interval_s : {0.0, 0.6}) {
    SCOPED_TRACE(interval_s);
    runtime::SteppedClock clock;
    Pipeline p;
    std::string error;
    AppConfig config = segmenting_config("rate", model_);
    config.segmentation.min_interval_s = interval_s;
    ASSERT_TRUE(p.init(config, &clock, &error)) << error;
    ASSERT_TRUE(p.segmentation().initialized());
    while (p.counters().keyframes_integrated < 8 && p.step()) {
    }
    p.request_stop();
    p.step();
    ASSERT_TRUE(p.finish(&error)) << error;
    const PipelineCounters& c = p.counters();
    const SegmentationWorkerCounters w = p.segmentation().counters();
    ASSERT_GE(c.keyframes_integrated, 8u);
    EXPECT_EQ(w.offered, c.keyframes_integrated) << "every integrated keyframe is offered";
    EXPECT_EQ(w.failed, 0u);
    EXPECT_EQ(w.stale, 0u);
    EXPECT_EQ(c.keyframes_segmented, w.collected);
    EXPECT_EQ(p.reconstruction().counters().label_frames, c.keyframes_segmented);
    EXPECT_EQ(c.keyframes_segmented + c.keyframes_unlabelled, c.keyframes_integrated);
    if (interval_s == 0.0) {
      // Lockstep: the worker is idle at every keyframe and the last one's labels are cast at the finish.
      EXPECT_EQ(c.keyframes_segmented, c.keyframes_integrated);
    } else {
      EXPECT_GT(c.keyframes_segmented, 0u);
      EXPECT_LT(c.keyframes_segmented, c.keyframes_integrated);
      EXPECT_EQ(w.too_soon, c.keyframes_unlabelled);
    }
    EXPECT_EQ(p.segmentation().cpu_stats().runs, w.labelled);
    EXPECT_EQ(p.segmentation_queue_stats().dropped, w.busy + w.too_soon + w.stale);
  }
}

TEST_F(SegmentationWorkerTest, TheConfigsCudaBackendReachesTheSegmenter) {
  runtime::SteppedClock clock;
  std::string error;
  AppConfig config = segmenting_config("cuda", model_);
  config.segmentation.backend = "cuda";
  config.segmentation.target = "cuda_fp16";
  ASSERT_EQ(config.check(), "");
  const bool cuda = segmentation::dnn_available(segmentation::DnnBackend::kCuda, segmentation::DnnTarget::kCudaFp16);
  {
    Pipeline p;
    const bool ok = p.init(config, &clock, &error);
    EXPECT_EQ(ok, cuda) << error;
    if (cuda) {
      EXPECT_EQ(p.segmentation().segmenter().active_backend(), segmentation::DnnBackend::kCuda);
      EXPECT_EQ(p.segmentation().segmenter().active_target(), segmentation::DnnTarget::kCudaFp16);
    } else {
      EXPECT_NE(error.find("backend cuda target cuda_fp16 is not available"), std::string::npos) << error;
    }
  }
  config.segmentation.fallback_to_cpu = true;
  Pipeline p;
  ASSERT_TRUE(p.init(config, &clock, &error)) << error;
  EXPECT_EQ(p.segmentation().segmenter().counters().backend_fallbacks, cuda ? 0u : 1u);
  EXPECT_EQ(p.segmentation().segmenter().active_backend(),
            cuda ? segmentation::DnnBackend::kCuda : segmentation::DnnBackend::kOpenCv);
  // A backend that does not go with its target is a config error naming both.
  config.segmentation.target = "cpu";
  EXPECT_NE(config.check().find("does not go with backend cuda"), std::string::npos) << config.check();
  config.segmentation.backend = "tensorrt";
  EXPECT_NE(config.check().find("segmentation.backend: expected opencv or cuda, got 'tensorrt'"), std::string::npos);
}

TEST(SegmentationConfigTest, JsonKeysReachTheConfig) {
  const std::string path = ::testing::TempDir() + "/qsg_segmentation_keys.json";
  std::ofstream(path) << R"({"segmentation": {"backend": "cuda", "target": "cuda_fp16", "fallback_to_cpu": true,
                                              "min_interval_s": 0.5, "deadline_s": 3.0, "opencv_threads": 2}})";
  AppConfig c;
  std::string error;
  ASSERT_TRUE(c.load(path, &error)) << error;
  EXPECT_EQ(c.segmentation.backend, "cuda");
  EXPECT_EQ(c.segmentation.target, "cuda_fp16");
  EXPECT_TRUE(c.segmentation.fallback_to_cpu);
  EXPECT_EQ(c.segmentation.min_interval_s, 0.5);
  EXPECT_EQ(c.segmentation.deadline_s, 3.0);
  EXPECT_EQ(c.segmentation.opencv_threads, 2);
  segmentation::DnnBackend b = segmentation::DnnBackend::kOpenCv;
  segmentation::DnnTarget t = segmentation::DnnTarget::kCpu;
  ASSERT_TRUE(segmentation::dnn_backend_from_string(c.segmentation.backend, &b));
  ASSERT_TRUE(segmentation::dnn_target_from_string(c.segmentation.target, &t));
  EXPECT_EQ(b, segmentation::DnnBackend::kCuda);
  EXPECT_EQ(t, segmentation::DnnTarget::kCudaFp16);
  std::ofstream(path) << R"({"segmentation": {"target": "gpu"}})";
  EXPECT_FALSE(c.load(path, &error));
  EXPECT_NE(error.find("segmentation.target: expected cpu, cuda or cuda_fp16, got 'gpu'"), std::string::npos) << error;
}

TEST(SegmentationWorkerSetupTest, RefusesAMissingSegmenterOrTooFewSlots) {
  SegmentationWorker w;
  std::string error;
  EXPECT_FALSE(w.init(nullptr, 2, SegmentationWorkerConfig{}, &error));
  EXPECT_NE(error.find("not initialised"), std::string::npos) << error;
  EXPECT_FALSE(w.initialized());
  auto frame = std::make_unique<messages::RgbdFrame>();
  EXPECT_FALSE(w.offer(*frame, Eigen::Isometry3d::Identity()));
  EXPECT_EQ(w.labelled(0), nullptr);
}

}  // namespace
}  // namespace qsg::app
