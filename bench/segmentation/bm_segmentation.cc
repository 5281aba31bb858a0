// BM_segmentation: the real ESPNetv2 (PASCAL VOC) network on the 640x480 TUM desk frame, per stage, on 1 and 2
// OpenCV threads, with the mean and max per frame and the heap allocations per frame; plus the pre- and
// post-processing alone on frozen synthetic input.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "bench/segmentation/malloc_count.h"
#include "core/segmentation/segmenter.h"

namespace {

using qsg::segmentation::Config;
using qsg::segmentation::LabelMap;
using qsg::segmentation::LogitsDecoder;
using qsg::segmentation::Normalization;
using qsg::segmentation::Preprocessor;
using qsg::segmentation::Segmenter;
using Clock = std::chrono::steady_clock;

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

// ../shared/data beside the repository, or $QSG_SHARED_DATA (as the tests look it up).
std::string shared_file(const std::string& relative) {
  const char* env = std::getenv("QSG_SHARED_DATA");
  const std::string dir = env != nullptr && exists(env) ? env : std::string(QSG_SOURCE_DIR) + "/../shared/data";
  const std::string path = dir + "/" + relative;
  return exists(path) ? path : std::string();
}

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

struct Setup {
  std::string error;  // non-empty: skip
  LabelMap map;
  Segmenter seg;
  std::unique_ptr<qsg::messages::RgbdFrame> frame = std::make_unique<qsg::messages::RgbdFrame>();
};

// Loaded once: the model (with its warm-up pass) and the TUM desk frame as RGB.
Setup& setup() {
  static Setup* s = [] {
    auto* out = new Setup;
    const std::string model = shared_file("models/espnetv2_s2_pascal384.onnx");
    const std::string color = shared_file("rgbd/redwood_open3d/RGBD/other_formats/TUM_color.png");
    if (model.empty() || color.empty()) {
      out->error = "shared data (models/espnetv2_s2_pascal384.onnx, TUM_color.png) not found beside the repository "
                   "or in $QSG_SHARED_DATA; skipping";
      return out;
    }
    if (!out->map.load(std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json",
                       &out->error))
      return out;
    Config config;
    config.model_path = model;
    if (!out->seg.init(config, out->map, &out->error)) return out;
    const cv::Mat bgr = cv::imread(color, cv::IMREAD_COLOR);
    if (bgr.cols != 640 || bgr.rows != 480) {
      out->error = color + ": expected a 640x480 colour image";
      return out;
    }
    out->frame->intrinsics.width = bgr.cols;
    out->frame->intrinsics.height = bgr.rows;
    cv::Mat rgb(bgr.rows, bgr.cols, CV_8UC3, out->frame->rgb.data());
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    return out;
  }();
  return *s;
}

// Arg: OpenCV threads. Reports per-stage means, the max per frame and heap allocations per frame (all threads).
void BM_segmentation(benchmark::State& state) {
  Setup& s = setup();
  if (!s.error.empty()) {
    state.SkipWithError(s.error.c_str());
    return;
  }
  const int threads = static_cast<int>(state.range(0));
  cv::setNumThreads(threads);
  std::string error;
  s.seg.segment(*s.frame, &error);  // one frame at this thread count before timing
  double pre_ms = 0.0, forward_ms = 0.0, post_ms = 0.0, max_ms = 0.0;
  std::int64_t forward_allocs = 0, forward_bytes = 0, our_allocs = 0;
  for (auto _ : state) {
    const Clock::time_point t0 = Clock::now();
    const std::int64_t a0 = qsg::bench::heap_allocations();
    s.seg.preprocess(*s.frame);
    const Clock::time_point t1 = Clock::now();
    const std::int64_t a1 = qsg::bench::heap_allocations();
    const std::int64_t b1 = qsg::bench::heap_allocated_bytes();
    const float* logits = s.seg.forward(&error);
    const Clock::time_point t2 = Clock::now();
    const std::int64_t a2 = qsg::bench::heap_allocations();
    forward_bytes += qsg::bench::heap_allocated_bytes() - b1;
    if (logits == nullptr) {
      state.SkipWithError(error.c_str());
      break;
    }
    s.seg.decoder().decode(logits, *s.frame);
    const std::int64_t a3 = qsg::bench::heap_allocations();
    const double post = ms_since(t2);
    pre_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
    forward_ms += std::chrono::duration<double, std::milli>(t2 - t1).count();
    post_ms += post;
    max_ms = std::max(max_ms, ms_since(t0));
    forward_allocs += a2 - a1;
    our_allocs += (a1 - a0) + (a3 - a2);
  }
  const double n = static_cast<double>(std::max<benchmark::IterationCount>(state.iterations(), 1));
  state.counters["opencv_threads"] = cv::getNumThreads();
  state.counters["pre_ms"] = pre_ms / n;
  state.counters["forward_ms"] = forward_ms / n;
  state.counters["post_ms"] = post_ms / n;
  state.counters["mean_ms"] = (pre_ms + forward_ms + post_ms) / n;
  state.counters["max_ms"] = max_ms;
  state.counters["forward_allocs_per_frame"] = qsg::bench::heap_allocations() < 0 ? -1.0 : forward_allocs / n;
  state.counters["forward_alloc_bytes_per_frame"] = qsg::bench::heap_allocations() < 0 ? -1.0 : forward_bytes / n;
  state.counters["our_allocs_per_frame"] = qsg::bench::heap_allocations() < 0 ? -1.0 : our_allocs / n;
  state.SetItemsProcessed(state.iterations());
}

// Pre-processing alone: 640x480 RGB (frozen pseudo-random) -> 1x3x384x384 normalised floats.
void BM_segmentation_preprocess(benchmark::State& state) {
  std::vector<std::uint8_t> rgb(640 * 480 * 3);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<std::uint8_t>((i * 2654435761u) >> 24);
  std::vector<float> blob(3 * 384 * 384);
  Preprocessor pre;
  std::string error;
  if (!pre.init(Normalization{}, 384, 384, &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  for (auto _ : state) {
    pre.run(rgb.data(), 640, 480, blob.data());
    benchmark::DoNotOptimize(blob.data());
  }
}

// Post-processing alone: 21 x 384 x 384 frozen logits -> 640x480 labels. Arg: min_confidence in percent
// (0 = argmax only, no softmax).
void BM_segmentation_postprocess(benchmark::State& state) {
  std::string json = R"({"network": "synthetic21", "classes": [)";
  for (int c = 0; c < 21; ++c)
    json += std::string(c ? "," : "") + R"({"name": "k)" + std::to_string(c) + R"(", "label": "chair"})";
  LabelMap map;
  std::string error;
  LogitsDecoder decoder;
  if (!map.parse(json + "]}", "synthetic21", &error) ||
      !decoder.init(map, 21, 384, 384, static_cast<float>(state.range(0)) / 100.0f, qsg::semantics::kUnlabeled,
                    &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  std::vector<float> logits(21u * 384u * 384u);
  for (std::size_t i = 0; i < logits.size(); ++i) logits[i] = static_cast<float>((i * 2654435761u) % 1000u) * 0.01f;
  auto frame = std::make_unique<qsg::messages::RgbdFrame>();
  frame->intrinsics.width = 640;
  frame->intrinsics.height = 480;
  for (auto _ : state) {
    decoder.decode(logits.data(), *frame);
    benchmark::DoNotOptimize(frame->labels.data());
  }
}

BENCHMARK(BM_segmentation)->Arg(1)->Arg(2)->ArgName("cv_threads")->Unit(benchmark::kMillisecond)->UseRealTime()
    ->MinTime(2.0);
BENCHMARK(BM_segmentation_preprocess)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_segmentation_postprocess)->Arg(0)->Arg(50)->ArgName("min_conf_pct")->Unit(benchmark::kMillisecond);

}  // namespace
