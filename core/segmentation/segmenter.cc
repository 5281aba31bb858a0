// Segmenter: ONNX loading and inference through OpenCV DNN around the allocation-free pre/post-processing.
#include "core/segmentation/segmenter.h"

#include <cstdio>
#include <exception>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <vector>

namespace qsg::segmentation {
namespace {

bool fail(std::string* error, const std::string& message) {
  if (error != nullptr) *error = message;
  return false;
}


std::string shape_string(const cv::Mat& m) {
  std::string s = "[";
  for (int d = 0; d < m.dims; ++d) s += (d ? " x " : "") + std::to_string(m.size[d]);
  return s + "]";
}

}  // namespace

int opencv_backend_id(DnnBackend backend) {
  return backend == DnnBackend::kCuda ? cv::dnn::DNN_BACKEND_CUDA : cv::dnn::DNN_BACKEND_OPENCV;
}

int opencv_target_id(DnnTarget target) {
  switch (target) {
    case DnnTarget::kCuda: return cv::dnn::DNN_TARGET_CUDA;
    case DnnTarget::kCudaFp16: return cv::dnn::DNN_TARGET_CUDA_FP16;
    case DnnTarget::kCpu: break;
  }
  return cv::dnn::DNN_TARGET_CPU;
}

bool dnn_available(DnnBackend backend, DnnTarget target) {
  const auto wanted = static_cast<cv::dnn::Target>(opencv_target_id(target));
  const std::vector<cv::dnn::Target> targets =
      cv::dnn::getAvailableTargets(static_cast<cv::dnn::Backend>(opencv_backend_id(backend)));
  for (cv::dnn::Target t : targets)
    if (t == wanted) return true;
  return false;
}

bool dnn_backend_from_string(const std::string& name, DnnBackend* out) {
  if (name == "opencv") *out = DnnBackend::kOpenCv;
  else if (name == "cuda") *out = DnnBackend::kCuda;
  else return false;
  return true;
}

bool dnn_target_from_string(const std::string& name, DnnTarget* out) {
  if (name == "cpu") *out = DnnTarget::kCpu;
  else if (name == "cuda") *out = DnnTarget::kCuda;
  else if (name == "cuda_fp16") *out = DnnTarget::kCudaFp16;
  else return false;
  return true;
}

const char* dnn_backend_name(DnnBackend backend) { return backend == DnnBackend::kCuda ? "cuda" : "opencv"; }
const char* dnn_target_name(DnnTarget target) {
  switch (target) {
    case DnnTarget::kCuda: return "cuda";
    case DnnTarget::kCudaFp16: return "cuda_fp16";
    case DnnTarget::kCpu: break;
  }
  return "cpu";
}

std::string Config::check() const {
  if (model_path.empty()) return "model_path is empty";
  if (input_width_px < 1 || input_width_px > 4096 || input_height_px < 1 || input_height_px > 4096)
    return "input_width_px/input_height_px must be in 1..4096";
  if (const std::string bad = normalization.check(); !bad.empty()) return "normalization." + bad;
  if (num_classes < 1 || num_classes > kMaxNetworkClasses)
    return "num_classes must be in 1.." + std::to_string(kMaxNetworkClasses);
  if (!(min_confidence >= 0.0f && min_confidence < 1.0f)) return "min_confidence must be in [0, 1)";
  if (low_confidence_label >= semantics::kNumObjectLabels) return "low_confidence_label is not an mpcat40 label";
  if (opencv_threads < 0 || opencv_threads > 64) return "opencv_threads must be in 0..64";
  if ((backend == DnnBackend::kCuda) != (target != DnnTarget::kCpu))
    return std::string("backend ") + dnn_backend_name(backend) + " cannot run target " + dnn_target_name(target) +
           " (opencv runs cpu; cuda runs cuda or cuda_fp16)";
  return {};
}

void Config::print(std::FILE* out) const {
  std::fprintf(out, "segmentation: model=%s input=%dx%d px ", model_path.c_str(), input_width_px, input_height_px);
  normalization.print(out);
  std::fprintf(out, " classes=%d min_confidence=%.3f low_confidence_label=%s backend=%s target=%s%s\n",
               num_classes, min_confidence, semantics::object_label(low_confidence_label).name,
               dnn_backend_name(backend), dnn_target_name(target), fallback_to_cpu ? " (cpu fallback allowed)" : "");
}

struct Segmenter::Impl {
  cv::dnn::Net net;
  cv::Mat blob;    // 1 x 3 x H x W input, written in place by the preprocessor every frame
  cv::Mat output;  // header onto OpenCV's output blob of the last forward()
  std::string output_name;
};

Segmenter::Segmenter() = default;
Segmenter::~Segmenter() = default;

bool Segmenter::init(const Config& config, const LabelMap& label_map, std::string* error) {
  ready_ = false;
  impl_.reset();
  if (const std::string bad = config.check(); !bad.empty()) return fail(error, "segmentation config: " + bad);
  if (label_map.empty()) return fail(error, "segmentation: the label map is empty (load it first)");
  if (!label_map.check_class_count(config.num_classes, error)) return false;
  const std::string& path = config.model_path;
  if (!std::ifstream(path, std::ios::binary)) return fail(error, "model file '" + path + "': cannot open");

  // A CUDA config on an OpenCV without CUDA would make OpenCV warn and quietly run on the CPU: refuse it, or fall
  // back openly when the config allows it.
  DnnBackend backend = config.backend;
  DnnTarget target = config.target;
  std::uint64_t fallbacks = 0;
  if (!dnn_available(backend, target)) {
    const std::string why = std::string("segmentation: backend ") + dnn_backend_name(backend) + " target " +
                            dnn_target_name(target) + " is not available in this OpenCV (" + CV_VERSION +
                            (cv::dnn::getAvailableTargets(cv::dnn::DNN_BACKEND_CUDA).empty()
                                 ? ", built without CUDA"
                                 : ", its CUDA backend lacks this target") +
                            "); on a Jetson use JetPack's OpenCV built with CUDA (segmentation/README.md), or set "
                            "backend opencv / target cpu";
    if (!config.fallback_to_cpu) return fail(error, why);
    std::fprintf(stderr, "%s: running on the CPU (fallback_to_cpu)\n", why.c_str());
    backend = DnnBackend::kOpenCv;
    target = DnnTarget::kCpu;
    fallbacks = 1;
  }
  if (config.opencv_threads > 0) cv::setNumThreads(config.opencv_threads);
  auto impl = std::make_unique<Impl>();
  try {
    impl->net = cv::dnn::readNetFromONNX(path);
  } catch (const cv::Exception& e) {
    return fail(error, "model file '" + path + "': OpenCV cannot read it as ONNX: " + e.what());
  } catch (const std::exception& e) {
    return fail(error, "model file '" + path + "': " + e.what());
  }
  if (impl->net.empty()) return fail(error, "model file '" + path + "': OpenCV read an empty network");

  const int shape[4] = {1, 3, config.input_height_px, config.input_width_px};
  try {
    impl->net.setPreferableBackend(opencv_backend_id(backend));
    impl->net.setPreferableTarget(opencv_target_id(target));
    const std::vector<std::string> outputs = impl->net.getUnconnectedOutLayersNames();
    if (outputs.size() != 1)
      return fail(error, "model file '" + path + "': expected one output, found " + std::to_string(outputs.size()));
    impl->output_name = outputs[0];
    impl->blob.create(4, shape, CV_32F);
    impl->blob.setTo(cv::Scalar(0.0));
    // Warm-up: checks the output shape and makes OpenCV allocate its layer buffers before the first frame.
    impl->net.setInput(impl->blob);
    impl->output = impl->net.forward(impl->output_name);
  } catch (const cv::Exception& e) {
    return fail(error, "model file '" + path + "': forward pass on a 1x3x" + std::to_string(config.input_height_px) +
                           "x" + std::to_string(config.input_width_px) + " input failed: " + e.what());
  } catch (const std::exception& e) {
    return fail(error, "model file '" + path + "': " + e.what());
  }
  const cv::Mat& out = impl->output;
  if (out.dims != 4 || out.size[0] != 1 || out.type() != CV_32F || !out.isContinuous())
    return fail(error, "model file '" + path + "': output '" + impl->output_name + "' has shape " + shape_string(out) +
                           ", expected continuous float 1 x classes x H x W");
  if (out.size[1] != config.num_classes)
    return fail(error, "model file '" + path + "': outputs " + std::to_string(out.size[1]) +
                           " classes, config num_classes is " + std::to_string(config.num_classes));
  if (!label_map.check_class_count(out.size[1], error)) return false;
  if (!decoder_.init(label_map, out.size[1], out.size[3], out.size[2], config.min_confidence,
                     config.low_confidence_label, error))
    return false;
  if (!preprocessor_.init(config.normalization, config.input_width_px, config.input_height_px, error)) return false;

  config_ = config;
  impl_ = std::move(impl);
  counters_ = Counters{};
  counters_.backend_fallbacks = fallbacks;
  active_backend_ = backend;
  active_target_ = target;
  ready_ = true;
  return true;
}

const float* Segmenter::preprocess(const messages::RgbdFrame& frame) {
  if (!ready_ || !frame.intrinsics.valid()) return nullptr;
  float* blob = impl_->blob.ptr<float>();
  preprocessor_.run(frame.rgb.data(), frame.width(), frame.height(), blob);
  return blob;
}

const float* Segmenter::forward(std::string* error) {
  if (!ready_) {
    fail(error, "segmentation: not initialised");
    return nullptr;
  }
  try {
    // OpenCV allocates inside forward() (about 3,500 blocks a frame for ESPNetv2, mostly per-layer temporaries:
    // bench/results/segmentation.md); forwarding into a kept output vector instead of by name changed nothing.
    impl_->net.setInput(impl_->blob);
    impl_->output = impl_->net.forward(impl_->output_name);
  } catch (const cv::Exception& e) {
    ++counters_.forward_errors;
    fail(error, "model file '" + config_.model_path + "': forward failed: " + e.what());
    return nullptr;
  }
  const cv::Mat& out = impl_->output;
  if (out.dims != 4 || out.type() != CV_32F || !out.isContinuous() || out.size[1] != decoder_.num_classes() ||
      out.size[2] != decoder_.logits_height_px() || out.size[3] != decoder_.logits_width_px()) {
    ++counters_.forward_errors;
    fail(error, "model file '" + config_.model_path + "': output shape changed to " + shape_string(out));
    return nullptr;
  }
  return out.ptr<float>();
}

const float* Segmenter::last_logits() const { return ready_ ? impl_->output.ptr<float>() : nullptr; }

bool Segmenter::segment(messages::RgbdFrame& frame, std::string* error) {
  if (!ready_) {
    ++counters_.bad_frames;
    return fail(error, "segmentation: not initialised");
  }
  if (!frame.intrinsics.valid()) {
    ++counters_.bad_frames;
    return fail(error, "segmentation: frame " + std::to_string(frame.sequence) + " has invalid intrinsics " +
                           std::to_string(frame.width()) + "x" + std::to_string(frame.height()));
  }
  preprocess(frame);
  const float* logits = forward(error);
  if (logits == nullptr) return false;
  decoder_.decode(logits, frame);
  counters_.low_confidence_pixels += decoder_.last_low_confidence_pixels();
  ++counters_.frames;
  return true;
}

}  // namespace qsg::segmentation
