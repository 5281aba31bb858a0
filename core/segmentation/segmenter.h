// Semantic segmentation of RGB-D frames with an ONNX network through OpenCV DNN: preprocess into a reused input
// blob, one forward pass, decode the logits into mpcat40 labels in RgbdFrame::labels.
//
// Allocation: our pre- and post-processing do not allocate after init(). OpenCV's forward() does (blob headers,
// layer bookkeeping); init() runs one warm-up pass so its buffers exist before the first frame. The per-frame
// count is measured in tests/segmentation and bench/segmentation and stated in core/segmentation/README.md.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "core/segmentation/label_map.h"
#include "core/segmentation/logits_decoder.h"
#include "core/segmentation/preprocess.h"
#include "core/semantics/labels.h"
#include "core/messages/sensor_types.h"

namespace qsg::segmentation {

// OpenCV DNN backend and target. CUDA needs an OpenCV built with it (JetPack's on the Xavier): init() checks
// cv::dnn::getAvailableTargets(DNN_BACKEND_CUDA) and refuses a CUDA config this OpenCV cannot run, naming it, or,
// with Config::fallback_to_cpu, runs on the CPU and counts the fallback (Counters::backend_fallbacks).
enum class DnnBackend { kOpenCv, kCuda };
enum class DnnTarget { kCpu, kCuda, kCudaFp16 };
const char* dnn_backend_name(DnnBackend backend);  // "opencv", "cuda": the config's spelling
const char* dnn_target_name(DnnTarget target);     // "cpu", "cuda", "cuda_fp16"
bool dnn_backend_from_string(const std::string& name, DnnBackend* out);  // false for an unknown name
bool dnn_target_from_string(const std::string& name, DnnTarget* out);
// The cv::dnn::Backend / cv::dnn::Target values passed to setPreferableBackend / setPreferableTarget.
int opencv_backend_id(DnnBackend backend);
int opencv_target_id(DnnTarget target);
// Whether this process's OpenCV can run the pair (the CPU always; CUDA only when OpenCV was built with it).
bool dnn_available(DnnBackend backend, DnnTarget target);

struct Config {
  std::string model_path;        // ONNX file
  int input_width_px = 384;      // network input size (espnetv2_s2_pascal384: 384 x 384)
  int input_height_px = 384;
  Normalization normalization;   // defaults: RGB, 1/255, ImageNet mean/std (MODELS.md for ESPNetv2 PASCAL)
  int num_classes = 21;          // the network's output channels (PASCAL VOC: 20 classes + background)
  // Softmax probability of the winning class below which a pixel is low_confidence_label (0: argmax only, which
  // skips the softmax). 0.5 = the winner must outweigh all others together; what it drops and costs on the TUM
  // desk frame: bench/results/segmentation.md ("min_confidence").
  float min_confidence = 0.5f;
  semantics::Label low_confidence_label = semantics::kUnlabeled;
  DnnBackend backend = DnnBackend::kOpenCv;
  DnnTarget target = DnnTarget::kCpu;
  // A CUDA backend this OpenCV cannot run: false = init() fails naming it; true = run on the CPU, counted.
  bool fallback_to_cpu = false;
  // > 0: init() calls cv::setNumThreads(opencv_threads) (process-wide: OpenCV has one pool); 0 leaves OpenCV's.
  int opencv_threads = 0;
  std::string check() const;  // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

struct Counters {
  std::uint64_t frames = 0;              // frames labelled
  std::uint64_t bad_frames = 0;          // refused: invalid intrinsics or not initialised
  std::uint64_t forward_errors = 0;      // OpenCV threw or returned an unexpected output
  std::uint64_t low_confidence_pixels = 0;  // at network resolution, summed over frames
  std::uint64_t backend_fallbacks = 0;   // init() ran a CUDA config on the CPU (Config::fallback_to_cpu)
};

class Segmenter {
 public:
  Segmenter();
  ~Segmenter();
  Segmenter(const Segmenter&) = delete;
  Segmenter& operator=(const Segmenter&) = delete;

  // Loads the model, checks that it outputs config.num_classes planes that the label map covers, sizes every
  // buffer and runs one warm-up pass. False with *error naming the file (model or label map) on any problem.
  bool init(const Config& config, const LabelMap& label_map, std::string* error);
  bool ready() const { return ready_; }

  // Labels frame.rgb (frame.width() x frame.height()) into frame.labels and sets has_labels. False (has_labels
  // untouched) when not ready, the frame's intrinsics are invalid or OpenCV fails; *error (optional) says why.
  bool segment(messages::RgbdFrame& frame, std::string* error = nullptr);

  // The stages of segment(), exposed for tests and benchmarks.
  const float* preprocess(const messages::RgbdFrame& frame);  // the network input blob (NCHW floats)
  const float* forward(std::string* error);                   // logits (NCHW floats) of the current blob
  const float* last_logits() const;                           // logits of the last forward(), or nullptr
  LogitsDecoder& decoder() { return decoder_; }

  const Config& config() const { return config_; }
  // What runs: the config's backend and target, or OpenCV/CPU after a counted fallback.
  DnnBackend active_backend() const { return active_backend_; }
  DnnTarget active_target() const { return active_target_; }
  const Counters& counters() const { return counters_; }
  // Output shape found at init: classes, height, width.
  int output_classes() const { return decoder_.num_classes(); }
  int output_height_px() const { return decoder_.logits_height_px(); }
  int output_width_px() const { return decoder_.logits_width_px(); }

 private:
  struct Impl;  // keeps OpenCV out of this header
  std::unique_ptr<Impl> impl_;
  Config config_;
  Preprocessor preprocessor_;
  LogitsDecoder decoder_;
  Counters counters_;
  DnnBackend active_backend_ = DnnBackend::kOpenCv;
  DnnTarget active_target_ = DnnTarget::kCpu;
  bool ready_ = false;
};

}  // namespace qsg::segmentation
