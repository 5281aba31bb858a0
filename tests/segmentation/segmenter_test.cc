// Segmenter: clear errors for missing or corrupt models and bad configs; with the shared data, the real ESPNetv2
// network labels the TUM desk frame (chairs and a table) and our pre/post-processing does not allocate.
#include "core/segmentation/segmenter.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <memory>
#include <opencv2/dnn.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/segmentation/test_files.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/test_data.h"

namespace qsg::segmentation {
namespace {

using testing::slow_tests_disabled;
using testing::write_temp_file;

constexpr const char* kModel = "models/espnetv2_s2_pascal384.onnx";
constexpr const char* kTumColor = "rgbd/redwood_open3d/RGBD/other_formats/TUM_color.png";

std::string shipped_config() {
  return std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json";
}

LabelMap pascal_map() {
  LabelMap map;
  std::string error;
  EXPECT_TRUE(map.load(shipped_config(), &error)) << error;
  return map;
}

TEST(Segmenter, MissingModelFileIsAClearError) {
  Config config;
  config.model_path = "/nonexistent/models/espnet.onnx";
  Segmenter seg;
  std::string error;
  EXPECT_FALSE(seg.init(config, pascal_map(), &error));
  EXPECT_FALSE(seg.ready());
  EXPECT_NE(error.find("/nonexistent/models/espnet.onnx"), std::string::npos) << error;
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;

  auto frame = std::make_unique<messages::RgbdFrame>();
  frame->has_labels = false;
  EXPECT_FALSE(seg.segment(*frame, &error));
  EXPECT_NE(error.find("not initialised"), std::string::npos) << error;
  EXPECT_FALSE(frame->has_labels);
  EXPECT_EQ(seg.counters().bad_frames, 1u);
}

TEST(Segmenter, CorruptModelFileIsAClearErrorNotAnException) {
  Config config;
  config.model_path = write_temp_file("corrupt.onnx", "this is not a protobuf \x01\x02\x03 onnx model");
  Segmenter seg;
  std::string error;
  EXPECT_FALSE(seg.init(config, pascal_map(), &error));
  EXPECT_NE(error.find(config.model_path), std::string::npos) << error;
  EXPECT_NE(error.find("ONNX"), std::string::npos) << error;

  config.model_path = write_temp_file("empty.onnx", "");
  EXPECT_FALSE(seg.init(config, pascal_map(), &error));
  EXPECT_NE(error.find(config.model_path), std::string::npos) << error;
}

TEST(Segmenter, BadConfigOrLabelMapNamesTheField) {
  Segmenter seg;
  std::string error;
  Config config;
  EXPECT_FALSE(seg.init(config, pascal_map(), &error));
  EXPECT_NE(error.find("model_path"), std::string::npos) << error;

  config.model_path = "whatever.onnx";
  config.num_classes = 0;
  EXPECT_FALSE(seg.init(config, pascal_map(), &error));
  EXPECT_NE(error.find("num_classes"), std::string::npos) << error;

  config.num_classes = 21;
  config.normalization.stddev[2] = -1.0f;
  EXPECT_FALSE(seg.init(config, pascal_map(), &error));
  EXPECT_NE(error.find("normalization.stddev[2]"), std::string::npos) << error;

  config.normalization = Normalization{};
  config.num_classes = 20;  // the label map has 21
  EXPECT_FALSE(seg.init(config, pascal_map(), &error));
  EXPECT_NE(error.find("segmentation_pascal_voc.json"), std::string::npos) << error;

  config.num_classes = 21;
  EXPECT_FALSE(seg.init(config, LabelMap{}, &error));
  EXPECT_NE(error.find("label map"), std::string::npos) << error;
}

TEST(Segmenter, ConfigPrintsEveryField) {
  Config config;
  config.model_path = "m.onnx";
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  config.print(f);
  std::rewind(f);
  char buf[512] = {};
  const std::size_t n = std::fread(buf, 1, sizeof(buf) - 1, f);
  std::fclose(f);
  const std::string text(buf, n);
  for (const char* key : {"model=m.onnx", "input=384x384", "mean=", "stddev=", "order=rgb", "classes=21",
                          "min_confidence=", "low_confidence_label=unlabeled", "backend=opencv", "target=cpu"})
    EXPECT_NE(text.find(key), std::string::npos) << key << " in " << text;
}

// The config's names map to the cv::dnn ids init() passes to setPreferableBackend / setPreferableTarget.
TEST(Segmenter, BackendAndTargetNamesMapToOpenCvIds) {
  DnnBackend b = DnnBackend::kOpenCv;
  DnnTarget t = DnnTarget::kCpu;
  ASSERT_TRUE(dnn_backend_from_string("cuda", &b));
  EXPECT_EQ(b, DnnBackend::kCuda);
  EXPECT_EQ(opencv_backend_id(b), cv::dnn::DNN_BACKEND_CUDA);
  ASSERT_TRUE(dnn_backend_from_string("opencv", &b));
  EXPECT_EQ(opencv_backend_id(b), cv::dnn::DNN_BACKEND_OPENCV);
  ASSERT_TRUE(dnn_target_from_string("cuda_fp16", &t));
  EXPECT_EQ(opencv_target_id(t), cv::dnn::DNN_TARGET_CUDA_FP16);
  ASSERT_TRUE(dnn_target_from_string("cuda", &t));
  EXPECT_EQ(opencv_target_id(t), cv::dnn::DNN_TARGET_CUDA);
  ASSERT_TRUE(dnn_target_from_string("cpu", &t));
  EXPECT_EQ(opencv_target_id(t), cv::dnn::DNN_TARGET_CPU);
  EXPECT_FALSE(dnn_backend_from_string("tensorrt", &b));
  EXPECT_FALSE(dnn_target_from_string("gpu", &t));
  for (DnnBackend x : {DnnBackend::kOpenCv, DnnBackend::kCuda}) {
    ASSERT_TRUE(dnn_backend_from_string(dnn_backend_name(x), &b));
    EXPECT_EQ(b, x);
  }
  for (DnnTarget x : {DnnTarget::kCpu, DnnTarget::kCuda, DnnTarget::kCudaFp16}) {
    ASSERT_TRUE(dnn_target_from_string(dnn_target_name(x), &t));
    EXPECT_EQ(t, x);
  }
  EXPECT_TRUE(dnn_available(DnnBackend::kOpenCv, DnnTarget::kCpu));
  // A backend with a target it cannot run is a config error naming both.
  Config config;
  config.model_path = "m.onnx";
  config.target = DnnTarget::kCudaFp16;
  EXPECT_NE(config.check().find("backend opencv cannot run target cuda_fp16"), std::string::npos) << config.check();
  config.backend = DnnBackend::kCuda;
  EXPECT_EQ(config.check(), "");
  config.target = DnnTarget::kCpu;
  EXPECT_NE(config.check().find("cuda"), std::string::npos);
}

// The real network, loaded once for the suite (load + warm-up pass is the expensive part).
class RealModel : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string model = ::qsg::testing::shared_data_file(kModel);
    if (model.empty() || slow_tests_disabled()) return;
    map_ = new LabelMap(pascal_map());
    seg_ = new Segmenter;
    Config config;
    config.model_path = model;
    if (!seg_->init(config, *map_, &init_error_)) {
      delete seg_;
      seg_ = nullptr;
    }
  }
  static void TearDownTestSuite() {
    delete seg_;
    delete map_;
    seg_ = nullptr;
    map_ = nullptr;
  }
  void SetUp() override {
    QSG_REQUIRE_SHARED_DATA(model, kModel);
    if (slow_tests_disabled()) GTEST_SKIP() << "QSG_SKIP_SLOW_TESTS set or running under qemu-user: skipping the real network";
    ASSERT_NE(seg_, nullptr) << init_error_;
  }

  // Loads the TUM desk frame (640 x 480) as RGB into a frame.
  static bool load_tum(messages::RgbdFrame& frame, const std::string& path) {
    const cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
    if (bgr.empty() || bgr.cols > messages::kMaxFrameWidth || bgr.rows > messages::kMaxFrameHeight) return false;
    frame.intrinsics.width = bgr.cols;
    frame.intrinsics.height = bgr.rows;
    cv::Mat rgb(bgr.rows, bgr.cols, CV_8UC3, frame.rgb.data());
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    frame.has_labels = false;
    return true;
  }

  static Segmenter* seg_;
  static LabelMap* map_;
  static std::string init_error_;
};
Segmenter* RealModel::seg_ = nullptr;
LabelMap* RealModel::map_ = nullptr;
std::string RealModel::init_error_;

TEST_F(RealModel, LoadsWith21ClassesAtInputResolution) {
  EXPECT_TRUE(seg_->ready());
  EXPECT_EQ(seg_->output_classes(), 21);
  EXPECT_EQ(seg_->output_height_px(), 384);
  EXPECT_EQ(seg_->output_width_px(), 384);
}

TEST_F(RealModel, LabelsTheTumDeskFrameWithChairsAndATable) {
  QSG_REQUIRE_SHARED_DATA(color, kTumColor);
  auto frame = std::make_unique<messages::RgbdFrame>();
  ASSERT_TRUE(load_tum(*frame, color)) << color;
  std::string error;
  ASSERT_TRUE(seg_->segment(*frame, &error)) << error;
  ASSERT_TRUE(frame->has_labels);

  std::array<int, semantics::kNumObjectLabels> histogram{};
  int invalid = 0;
  for (int i = 0; i < frame->pixels(); ++i) {
    const semantics::Label l = frame->labels[static_cast<std::size_t>(i)];
    if (l < semantics::kNumObjectLabels) ++histogram[l]; else ++invalid;
  }
  const double n = frame->pixels();
  const double chair = histogram[semantics::kChair] / n;
  const double table = histogram[semantics::kTable] / n;
  const double unlabeled = histogram[semantics::kUnlabeled] / n;
  std::printf("TUM desk frame: chair %.1f %%, table %.1f %%, unlabeled %.1f %%\n", 100 * chair, 100 * table,
              100 * unlabeled);
  EXPECT_EQ(invalid, 0);
  // MODELS.md: about 12 % chair and 11 % diningtable.
  EXPECT_GE(chair, 0.05);
  EXPECT_GE(table, 0.05);
  // Every pixel is a label the PASCAL map can produce.
  int outside_map = 0;
  for (int l = 0; l < semantics::kNumObjectLabels; ++l) {
    bool mapped = false;
    for (int c = 0; c < map_->num_classes(); ++c) mapped = mapped || map_->label(c) == l;
    if (!mapped) outside_map += histogram[static_cast<std::size_t>(l)];
  }
  EXPECT_EQ(outside_map, 0);
  EXPECT_GE(unlabeled, 0.3);  // most of the desk scene is VOC background (monitor, walls, desk clutter)

  // The default min_confidence (0.5) only drops uncertain pixels: argmax alone on the same logits labels at least
  // as many chair and table pixels, and the dropped share is small.
  EXPECT_EQ(seg_->config().min_confidence, 0.5f);
  const double low = static_cast<double>(seg_->decoder().last_low_confidence_pixels()) / (384.0 * 384.0);
  LogitsDecoder argmax_only;
  std::string error2;
  ASSERT_TRUE(argmax_only.init(*map_, 21, 384, 384, 0.0f, semantics::kUnlabeled, &error2)) << error2;
  ASSERT_TRUE(argmax_only.decode(seg_->last_logits(), *frame));
  int chair_argmax = 0, table_argmax = 0;
  for (int i = 0; i < frame->pixels(); ++i) {
    chair_argmax += frame->labels[static_cast<std::size_t>(i)] == semantics::kChair;
    table_argmax += frame->labels[static_cast<std::size_t>(i)] == semantics::kTable;
  }
  std::printf("min_confidence 0.5 drops %.1f %% of network pixels; argmax only: chair %.1f %%, table %.1f %%\n",
              100 * low, 100 * chair_argmax / n, 100 * table_argmax / n);
  EXPECT_GE(chair_argmax, histogram[semantics::kChair]);
  EXPECT_GE(table_argmax, histogram[semantics::kTable]);
  EXPECT_GT(low, 0.0);
  EXPECT_LT(low, 0.2);
}

TEST_F(RealModel, OurStagesDoNotAllocateAfterWarmUp) {
  QSG_REQUIRE_SHARED_DATA(color, kTumColor);
  auto frame = std::make_unique<messages::RgbdFrame>();
  ASSERT_TRUE(load_tum(*frame, color)) << color;

  // The stages of segment() one by one (init's warm-up pass was the first frame); operator new counted per stage.
  const float* blob = nullptr;
  EXPECT_NO_ALLOCATIONS(blob = seg_->preprocess(*frame));
  ASSERT_NE(blob, nullptr);
  std::string error;
  const float* logits = nullptr;
  std::uint64_t forward_allocs = 0, forward_bytes = 0;
  {
    ::qsg::testing::AllocationCounter counter;
    logits = seg_->forward(&error);
    forward_allocs = counter.allocations();
    forward_bytes = counter.bytes();
  }
  ASSERT_NE(logits, nullptr) << error;
  bool decoded = false;
  EXPECT_NO_ALLOCATIONS(decoded = seg_->decoder().decode(logits, *frame));
  EXPECT_TRUE(decoded);
  // OpenCV is not allocation-free: report its count (operator new on the calling thread; cv::Mat data goes through
  // cv::fastMalloc, which this hook does not see: bench/segmentation counts malloc on all threads as well).
  std::printf("OpenCV forward(): %llu operator-new calls, %llu bytes on the calling thread\n",
              static_cast<unsigned long long>(forward_allocs), static_cast<unsigned long long>(forward_bytes));
  RecordProperty("forward_operator_new_calls", static_cast<int>(forward_allocs));

  // The stage-by-stage path labels the frame as segment() does.
  int chair = 0;
  for (int i = 0; i < frame->pixels(); ++i) chair += frame->labels[static_cast<std::size_t>(i)] == semantics::kChair;
  EXPECT_GE(chair, frame->pixels() / 20);
}

TEST(RealModelInit, NetworkClassCountDifferentFromConfigIsRefused) {
  QSG_REQUIRE_SHARED_DATA(model, kModel);
  if (slow_tests_disabled()) GTEST_SKIP() << "QSG_SKIP_SLOW_TESTS set or running under qemu-user: skipping the real network";
  // A 20-class map and config against the 21-class network: the error names the model and both counts.
  std::string json = R"({"network": "wrong", "classes": [)";
  for (int c = 0; c < 20; ++c)
    json += std::string(c ? "," : "") + R"({"name": "k)" + std::to_string(c) + R"(", "label": "chair"})";
  LabelMap twenty;
  std::string error;
  ASSERT_TRUE(twenty.parse(json + "]}", "twenty.json", &error)) << error;
  Config config;
  config.model_path = model;
  config.num_classes = 20;
  Segmenter seg;
  EXPECT_FALSE(seg.init(config, twenty, &error));
  EXPECT_FALSE(seg.ready());
  EXPECT_NE(error.find(model), std::string::npos) << error;
  EXPECT_NE(error.find("outputs 21 classes"), std::string::npos) << error;
  EXPECT_NE(error.find("20"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::segmentation

// CUDA selected by config: with an OpenCV built with CUDA (JetPack) init() selects it; with Debian's (no CUDA) it
// is a clear error naming the backend, or, with fallback_to_cpu, a counted fallback that labels as the CPU does.
namespace qsg::segmentation {
namespace {
TEST(RealModelInit, CudaConfigSelectsCudaOrFailsClearlyOrFallsBackCounted) {
  QSG_REQUIRE_SHARED_DATA(model, kModel);
  if (slow_tests_disabled()) GTEST_SKIP() << "QSG_SKIP_SLOW_TESTS set or running under qemu-user: skipping the real network";
  Config config;
  config.model_path = model;
  config.backend = DnnBackend::kCuda;
  config.target = DnnTarget::kCudaFp16;
  Segmenter seg;
  std::string error;
  if (dnn_available(DnnBackend::kCuda, DnnTarget::kCudaFp16)) {
    ASSERT_TRUE(seg.init(config, pascal_map(), &error)) << error;
    EXPECT_EQ(seg.active_backend(), DnnBackend::kCuda);
    EXPECT_EQ(seg.active_target(), DnnTarget::kCudaFp16);
    EXPECT_EQ(seg.counters().backend_fallbacks, 0u);
    return;
  }
  EXPECT_FALSE(seg.init(config, pascal_map(), &error));
  EXPECT_FALSE(seg.ready());
  EXPECT_NE(error.find("backend cuda target cuda_fp16 is not available"), std::string::npos) << error;
  EXPECT_NE(error.find("without CUDA"), std::string::npos) << error;

  config.fallback_to_cpu = true;
  ASSERT_TRUE(seg.init(config, pascal_map(), &error)) << error;
  EXPECT_EQ(seg.counters().backend_fallbacks, 1u);
  EXPECT_EQ(seg.active_backend(), DnnBackend::kOpenCv);
  EXPECT_EQ(seg.active_target(), DnnTarget::kCpu);
  // The fallback labels a frame exactly as a CPU config does.
  QSG_REQUIRE_SHARED_DATA(color, kTumColor);
  const cv::Mat bgr = cv::imread(color, cv::IMREAD_COLOR);
  ASSERT_FALSE(bgr.empty());
  auto a = std::make_unique<messages::RgbdFrame>();
  a->intrinsics.width = bgr.cols;
  a->intrinsics.height = bgr.rows;
  cv::Mat rgb(bgr.rows, bgr.cols, CV_8UC3, a->rgb.data());
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  auto b = std::make_unique<messages::RgbdFrame>(*a);
  ASSERT_TRUE(seg.segment(*a, &error)) << error;
  Config cpu;
  cpu.model_path = model;
  Segmenter reference;
  ASSERT_TRUE(reference.init(cpu, pascal_map(), &error)) << error;
  EXPECT_EQ(reference.counters().backend_fallbacks, 0u);
  ASSERT_TRUE(reference.segment(*b, &error)) << error;
  EXPECT_TRUE(std::equal(a->labels.begin(), a->labels.begin() + a->pixels(), b->labels.begin()));
}
}  // namespace
}  // namespace qsg::segmentation
