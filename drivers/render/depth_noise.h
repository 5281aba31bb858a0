// Depth noise of a structured-light / active-stereo camera applied to rendered depth: axial Gaussian noise growing
// with the square of the depth, quantisation to the device depth unit, and dropouts at grazing incidence.
// Deterministic per (seed, frame sequence, pixel) through a counter-based hash, independent of pixel order.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace qsg::render {

struct DepthNoiseConfig {
  bool enabled = false;  // off: rendered depth is exact
  // Axial sigma(z) = sigma_base_m + sigma_quadratic_per_m * z^2. Defaults follow the Kinect v1 fit of Nguyen,
  // Izadi and Lovell (3DIMPVT 2012), 0.0012 + 0.0019 (z - 0.4)^2, without the 0.4 m offset: 1.4 mm at 0.3 m,
  // 8.8 mm at 2 m, 31.6 mm at 4 m. Set both to zero for quantisation and dropouts only.
  double sigma_base_m = 0.0012;
  double sigma_quadratic_per_m = 0.0019;
  bool quantize = true;  // round to multiples of the frame's depth_scale_m, as a device's integer output is
  // Dropout probability rises linearly from 0 at grazing_start_deg to 1 at grazing_full_deg (angle between the
  // viewing ray and the surface normal); real sensors lose the pattern on surfaces seen edge-on.
  double grazing_start_deg = 75.0;
  double grazing_full_deg = 88.0;
  double dropout_probability = 0.0;  // extra uniform dropouts on every valid pixel (speckle, IR absorption)

  // Empty when usable, else the first bad field and why.
  std::string check() const;
  void print(std::FILE* out) const;
};

class DepthNoise {
 public:
  // The config must have passed check().
  void configure(const DepthNoiseConfig& config, std::uint64_t seed);
  const DepthNoiseConfig& config() const { return config_; }

  // Key of one frame; every pixel's randomness derives from it and the pixel index.
  std::uint64_t frame_key(std::uint64_t sequence) const;
  // Noisy depth of one pixel, or 0 when the return drops out. cos_incidence = |cos| of the angle between the
  // viewing ray and the surface normal; depth_scale_m <= 0 disables quantisation.
  float apply(std::uint64_t frame_key, std::uint32_t pixel, double depth_m, double cos_incidence,
              double depth_scale_m) const;
  // Standard deviation of the axial noise at a depth.
  double sigma_m(double depth_m) const {
    return config_.sigma_base_m + config_.sigma_quadratic_per_m * depth_m * depth_m;
  }

 private:
  DepthNoiseConfig config_;
  std::uint64_t seed_key_ = 0;
  double cos_start_ = 0.0;  // cos(grazing_start_deg)
  double start_rad_ = 0.0;
  double inv_span_rad_ = 0.0;
};

}  // namespace qsg::render
