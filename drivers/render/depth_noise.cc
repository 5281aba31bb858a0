// Depth noise model (see depth_noise.h).
#include "drivers/render/depth_noise.h"

#include <cmath>

#include "drivers/render/counter_hash.h"

namespace qsg::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

}  // namespace

std::string DepthNoiseConfig::check() const {
  char buffer[200];
  if (!(std::isfinite(sigma_base_m) && sigma_base_m >= 0.0)) {
    std::snprintf(buffer, sizeof(buffer), "noise.sigma_base_m must be >= 0 and finite (got %g)", sigma_base_m);
    return buffer;
  }
  if (!(std::isfinite(sigma_quadratic_per_m) && sigma_quadratic_per_m >= 0.0)) {
    std::snprintf(buffer, sizeof(buffer), "noise.sigma_quadratic_per_m must be >= 0 and finite (got %g)",
                  sigma_quadratic_per_m);
    return buffer;
  }
  if (!(grazing_start_deg >= 0.0 && grazing_start_deg < grazing_full_deg && grazing_full_deg <= 90.0)) {
    std::snprintf(buffer, sizeof(buffer),
                  "noise.grazing_start_deg / grazing_full_deg need 0 <= start < full <= 90 (got %g, %g)",
                  grazing_start_deg, grazing_full_deg);
    return buffer;
  }
  if (!(dropout_probability >= 0.0 && dropout_probability <= 1.0)) {
    std::snprintf(buffer, sizeof(buffer), "noise.dropout_probability must be in [0, 1] (got %g)", dropout_probability);
    return buffer;
  }
  return {};
}

void DepthNoiseConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "depth_noise: enabled=%s sigma_base_m=%g sigma_quadratic_per_m=%g quantize=%s grazing_start_deg=%g "
               "grazing_full_deg=%g dropout_probability=%g\n",
               enabled ? "true" : "false", sigma_base_m, sigma_quadratic_per_m, quantize ? "true" : "false",
               grazing_start_deg, grazing_full_deg, dropout_probability);
}

void DepthNoise::configure(const DepthNoiseConfig& config, std::uint64_t seed) {
  config_ = config;
  seed_key_ = mix64(seed ^ 0x5DEECE66Dull);
  start_rad_ = config.grazing_start_deg * kDegToRad;
  cos_start_ = std::cos(start_rad_);
  inv_span_rad_ = 1.0 / ((config.grazing_full_deg - config.grazing_start_deg) * kDegToRad);
}

std::uint64_t DepthNoise::frame_key(std::uint64_t sequence) const { return hash_combine(seed_key_, sequence); }

float DepthNoise::apply(std::uint64_t key, std::uint32_t pixel, double depth_m, double cos_incidence,
                        double depth_scale_m) const {
  double p_drop = config_.dropout_probability;
  if (cos_incidence < cos_start_) {
    const double angle = std::acos(std::max(0.0, std::min(1.0, cos_incidence)));
    p_drop = std::max(p_drop, std::min(1.0, (angle - start_rad_) * inv_span_rad_));
  }
  if (p_drop > 0.0) {
    const double u_drop = unit_double_open0(hash_combine(key, 2ull * pixel)) - 0x1p-53;  // [0, 1)
    if (u_drop < p_drop) return 0.0f;
  }

  double z = depth_m;
  const double sigma = sigma_m(depth_m);
  if (sigma > 0.0) {
    // Box-Muller from one 64-bit hash: 32 bits per uniform is ample for a sensor model.
    const std::uint64_t h = hash_combine(key, 2ull * pixel + 1ull);
    const double u1 = (static_cast<double>(h >> 32) + 1.0) * 0x1p-32;    // (0, 1]
    const double u2 = static_cast<double>(h & 0xFFFFFFFFull) * 0x1p-32;  // [0, 1)
    const double gauss = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
    z += sigma * gauss;
  }
  if (config_.quantize && depth_scale_m > 0.0) z = std::nearbyint(z / depth_scale_m) * depth_scale_m;
  return z > 0.0 ? static_cast<float>(z) : 0.0f;
}

}  // namespace qsg::render
