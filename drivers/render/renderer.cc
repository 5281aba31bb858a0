// Per-pixel ray casting into the compiled scene, shading, labels and the depth noise model (see renderer.h).
#include "drivers/render/renderer.h"

#include <cmath>
#include <cstdarg>

#include "drivers/render/shading.h"

namespace qsg::render {
namespace {

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* fmt, ...) {
  char buffer[256];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buffer, sizeof(buffer), fmt, args);
  va_end(args);
  return buffer;
}

// Rays start just off the camera centre so a surface through the centre itself is not reported at t = 0.
constexpr double kRayStartM = 1e-6;

}  // namespace

void RendererCounters::print(std::FILE* out) const {
  std::fprintf(out,
               "renderer counters: frames=%llu rejected_frames=%llu rays=%llu hits=%llu too_near=%llu "
               "dropouts=%llu\n",
               static_cast<unsigned long long>(frames), static_cast<unsigned long long>(rejected_frames),
               static_cast<unsigned long long>(rays), static_cast<unsigned long long>(hits),
               static_cast<unsigned long long>(too_near), static_cast<unsigned long long>(dropouts));
}

std::string Renderer::Config::check() const {
  if (!(std::isfinite(min_range_m) && min_range_m >= 0.0))
    return format("min_range_m must be >= 0 and finite (got %g)", min_range_m);
  if (!(std::isfinite(max_range_m) && max_range_m > min_range_m))
    return format("max_range_m must be finite and above min_range_m (got %g, min %g)", max_range_m, min_range_m);
  if (noise.enabled) return noise.check();
  return {};
}

void Renderer::Config::print(std::FILE* out) const {
  std::fprintf(out, "renderer: min_range_m=%g max_range_m=%g seed=%llu\n", min_range_m, max_range_m,
               static_cast<unsigned long long>(seed));
  noise.print(out);
}

std::string check_intrinsics(const messages::CameraIntrinsics& k) {
  if (k.width <= 0 || k.width > messages::kMaxFrameWidth)
    return format("intrinsics.width must be in 1..%d (got %d)", messages::kMaxFrameWidth, k.width);
  if (k.height <= 0 || k.height > messages::kMaxFrameHeight)
    return format("intrinsics.height must be in 1..%d (got %d)", messages::kMaxFrameHeight, k.height);
  if (!(std::isfinite(k.fx) && k.fx > 0.0)) return format("intrinsics.fx must be positive and finite (got %g)", k.fx);
  if (!(std::isfinite(k.fy) && k.fy > 0.0)) return format("intrinsics.fy must be positive and finite (got %g)", k.fy);
  if (!std::isfinite(k.cx)) return format("intrinsics.cx must be finite (got %g)", k.cx);
  if (!std::isfinite(k.cy)) return format("intrinsics.cy must be finite (got %g)", k.cy);
  return {};
}

bool Renderer::init(const Config& config, const world::World& world, std::string* error) {
  ready_ = false;
  const std::string bad = config.check();
  if (!bad.empty()) {
    if (error) *error = "renderer config: " + bad;
    return false;
  }
  if (!scene_.build(world, error)) return false;
  config_ = config;
  noise_.configure(config.noise, config.seed);
  counters_ = RendererCounters{};
  ready_ = true;
  return true;
}

bool Renderer::render(const Eigen::Isometry3d& world_T_camera, const messages::CameraIntrinsics& k,
                      std::uint64_t sequence, messages::RgbdFrame& frame, std::string* error) {
  if (!ready_) {
    if (error) *error = "renderer: render() before a successful init()";
    ++counters_.rejected_frames;
    return false;
  }
  const std::string bad = check_intrinsics(k);
  if (!bad.empty()) {
    if (error) *error = "renderer: " + bad;
    ++counters_.rejected_frames;
    return false;
  }
  const Eigen::Matrix3d R = world_T_camera.linear();
  const Eigen::Vector3d origin = world_T_camera.translation();
  if (!R.allFinite() || !origin.allFinite() || (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
      R.determinant() <= 0.0) {
    if (error) *error = "renderer: world_T_camera must be a finite rigid transform (orthonormal rotation)";
    ++counters_.rejected_frames;
    return false;
  }

  frame.intrinsics = k;
  frame.sequence = sequence;
  frame.has_labels = true;
  const int width = k.width, height = k.height;
  const double inv_fx = 1.0 / k.fx, inv_fy = 1.0 / k.fy;
  const bool noisy = config_.noise.enabled;
  const std::uint64_t key = noise_.frame_key(sequence);
  const double depth_scale_m = static_cast<double>(frame.depth_scale_m);
  const Eigen::Vector3d col_x = R.col(0);
  std::uint64_t hits = 0, too_near = 0, dropouts = 0;

  // The previous pixel's primitive is tested first (see RayScene::intersect); rows start from the row above.
  std::uint32_t row_hint = kNoPrimitive;
  for (int v = 0; v < height; ++v) {
    std::uint32_t hint = row_hint;
    // Direction with unit optical-axis component, so the ray parameter is the z-depth.
    const Eigen::Vector3d row_dir = R.col(2) + R.col(1) * ((v - k.cy) * inv_fy);
    for (int u = 0; u < width; ++u) {
      const int idx = v * width + u;
      const Eigen::Vector3d dir = row_dir + col_x * ((u - k.cx) * inv_fx);
      RayHit hit;
      std::uint8_t* rgb = &frame.rgb[3 * static_cast<std::size_t>(idx)];
      const bool found = scene_.intersect(origin, dir, kRayStartM, config_.max_range_m, &hit, hint);
      if (found) hint = hit.primitive;
      if (u == 0) row_hint = found ? hit.primitive : kNoPrimitive;
      if (!found) {
        frame.depth_m[idx] = 0.0f;
        frame.labels[idx] = semantics::kVoid;
        rgb[0] = rgb[1] = rgb[2] = 0;
        continue;
      }
      ++hits;
      const world::Material& material = scene_.material(hit.shape);
      const Eigen::Vector3d point = origin + hit.t * dir;
      const Eigen::Vector3d view = dir / dir.norm();
      shade(material, point, hit.normal, view, rgb);
      frame.labels[idx] = material.label;
      if (hit.t < config_.min_range_m) {
        ++too_near;
        frame.depth_m[idx] = 0.0f;
      } else if (noisy) {
        const float z =
            noise_.apply(key, static_cast<std::uint32_t>(idx), hit.t, std::fabs(hit.normal.dot(view)), depth_scale_m);
        if (z == 0.0f) ++dropouts;
        frame.depth_m[idx] = z;
      } else {
        frame.depth_m[idx] = static_cast<float>(hit.t);
      }
    }
  }
  ++counters_.frames;
  counters_.rays += static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
  counters_.hits += hits;
  counters_.too_near += too_near;
  counters_.dropouts += dropouts;
  return true;
}

}  // namespace qsg::render
