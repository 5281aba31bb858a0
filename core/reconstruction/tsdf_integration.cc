// Semantic TSDF integration: blocks allocated along the frame's rays (evicting the farthest when full), each
// touched block's voxels projected into the frame and fused (distance, weight, colour, label votes), in parallel
// over the touched blocks; and the label votes of a frame whose labels came late.
#include "core/reconstruction/semantic_tsdf_internal.h"

namespace qsg::reconstruction {

std::uint32_t SemanticTsdf::allocate_block(const memory::Index3& index, const Eigen::Vector3d& robot_m) {
  if (const std::uint32_t* h = block_index_.find(index)) return *h;
  if (blocks_.full() && !evict_farthest(robot_m)) {
    ++counters_.blocks_refused;
    return memory::kInvalidHandle;
  }
  const std::uint32_t h = blocks_.acquire();
  if (h == memory::kInvalidHandle) return h;
  if (block_index_.insert(index, h) == nullptr) {
    blocks_.release(h);
    ++counters_.blocks_refused;
    return memory::kInvalidHandle;
  }
  blocks_[h].index = index;
  ++counters_.blocks_allocated;
  return h;
}

bool SemanticTsdf::evict_farthest(const Eigen::Vector3d& robot_m) {
  std::uint32_t best = memory::kInvalidHandle;
  double best_d2 = -1.0;
  for (std::uint32_t h = 0; h < blocks_.capacity(); ++h) {
    if (!blocks_.live(h) || blocks_[h].frame_stamp == frame_stamp_) continue;  // never a block of this frame
    const double d2 = (block_center(blocks_[h].index) - robot_m).squaredNorm();
    if (d2 > best_d2) {
      best_d2 = d2;
      best = h;
    }
  }
  if (best == memory::kInvalidHandle) return false;
  if (!logged_eviction_) {
    std::fprintf(stderr,
                 "reconstruction: block pool full (%zu blocks): archiving the farthest blocks early "
                 "(logged once; see counters().blocks_evicted)\n",
                 blocks_.capacity());
    logged_eviction_ = true;
  }
  archive_block(best);
  ++counters_.blocks_evicted;
  return true;
}

bool SemanticTsdf::integrate(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera) {
  if (!ready_ || !frame.intrinsics.valid() || !world_T_camera.matrix().allFinite()) return false;
  ++frame_stamp_;
  ++counters_.frames;
  touched_.clear();
  const messages::CameraIntrinsics& in = frame.intrinsics;
  const float min_m = static_cast<float>(config_.min_range_m), max_m = static_cast<float>(config_.max_range_m);
  const float trunc = static_cast<float>(config_.voxel_size_m * config_.truncation_voxels);
  const double block_m = config_.voxel_size_m * kBlockSide;
  const Eigen::Vector3d robot_m = world_T_camera.translation();

  // Counting the valid pixels is the first pass over the frame's 1.2 MB of depth (memory-bound): split it
  // over the integration threads too.
  const int n = frame.pixels();
  std::uint64_t valid = 0;
  if (workers_ == nullptr) {
    for (int i = 0; i < n; ++i) valid += valid_depth(frame.depth_m[static_cast<std::size_t>(i)], min_m, max_m) ? 1 : 0;
  } else {
    constexpr std::uint32_t kParts = 8;
    struct Count {
      const float* depth;
      int n;
      float min_m, max_m;
      std::uint64_t valid[kParts];
    } count{frame.depth_m.data(), n, min_m, max_m, {}};
    workers_->run(
        [](void* c, std::uint32_t part) {
          Count& k = *static_cast<Count*>(c);
          const int begin = static_cast<int>(static_cast<long>(k.n) * part / kParts);
          const int end = static_cast<int>(static_cast<long>(k.n) * (part + 1) / kParts);
          std::uint64_t v = 0;
          for (int i = begin; i < end; ++i) v += valid_depth(k.depth[i], k.min_m, k.max_m) ? 1 : 0;
          k.valid[part] = v;
        },
        &count, kParts);
    for (std::uint64_t v : count.valid) valid += v;
  }
  counters_.pixels_valid += valid;
  counters_.pixels_invalid += static_cast<std::uint64_t>(n) - valid;

  // Allocation: pixels on a grid whose spacing spans at most one voxel at maximum range, each allocating the
  // blocks at the start, middle and end of its truncation band (the band, 2 x truncation, is shorter than a
  // block, so three samples touch every block it crosses).
  // |fy|: a negative fy (ICL-NUIM's image y axis points up) is as fine a grid as a positive one.
  const int stride =
      std::max(1, static_cast<int>(config_.voxel_size_m * std::min(in.fx, std::abs(in.fy)) / config_.max_range_m));
  const Eigen::Matrix3d R = world_T_camera.linear();
  for (int v = 0; v < in.height; v += stride) {
    for (int u = 0; u < in.width; u += stride) {
      const float d = frame.depth_m[static_cast<std::size_t>(v * in.width + u)];
      if (!valid_depth(d, min_m, max_m)) continue;
      const Eigen::Vector3d ray((u - in.cx) / in.fx, (v - in.cy) / in.fy, 1.0);
      const Eigen::Vector3d dir = R * ray;
      for (int k = -1; k <= 1; ++k) {
        const Eigen::Vector3d p = robot_m + dir * (d + k * trunc);
        const memory::Index3 bi{static_cast<std::int32_t>(std::floor(p.x() / block_m)),
                                static_cast<std::int32_t>(std::floor(p.y() / block_m)),
                                static_cast<std::int32_t>(std::floor(p.z() / block_m))};
        const std::uint32_t h = allocate_block(bi, robot_m);
        if (h == memory::kInvalidHandle) continue;
        Block& b = blocks_[h];
        if (b.frame_stamp != frame_stamp_) {
          b.frame_stamp = frame_stamp_;
          b.time_sum_s += static_cast<double>(frame.sample_time_ns) * 1e-9;
          ++b.time_frames;
          touched_.push_back(h);
        }
      }
    }
  }
  const Eigen::Isometry3d camera_T_world = world_T_camera.inverse();
  const std::uint32_t count = static_cast<std::uint32_t>(touched_.size());
  if (workers_ == nullptr || count < 2) {
    integrate_range(frame, camera_T_world, 0, count);
  } else {
    // Blocks are independent (a block's voxels are written by its own job only), so the result is the same
    // bits as on one thread. Jobs of 4 blocks keep the shared counter cold.
    struct Context {
      SemanticTsdf* self;
      const messages::RgbdFrame* frame;
      const Eigen::Isometry3d* camera_T_world;
      std::uint32_t count;
    } context{this, &frame, &camera_T_world, count};
    constexpr std::uint32_t kPerJob = 4;
    workers_->run(
        [](void* c, std::uint32_t job) {
          const Context& ctx = *static_cast<const Context*>(c);
          ctx.self->integrate_range(*ctx.frame, *ctx.camera_T_world, job * kPerJob,
                                    std::min(ctx.count, (job + 1) * kPerJob));
        },
        &context, (count + kPerJob - 1) / kPerJob);
  }
  for (std::uint32_t h : touched_) blocks_[h].dirty = true;
  return true;
}

namespace {

// One label observation of weight w into the voxel's two (label, weight) pairs (see LabelVote: Misra-Gries).
void add_label_vote(Voxel& vx, semantics::Label l, float w) {
  const std::uint16_t wq = static_cast<std::uint16_t>(std::max(1L, std::lround(w * kWeightScale)));
  LabelVote* votes = vx.votes;
  LabelVote* hit = nullptr;
  for (int k = 0; k < kLabelPairs; ++k)
    if (votes[k].weight_q > 0 && votes[k].label == l) hit = &votes[k];
  if (hit == nullptr)
    for (int k = 0; k < kLabelPairs && hit == nullptr; ++k)
      if (votes[k].weight_q == 0) {
        hit = &votes[k];
        hit->label = l;
      }
  if (hit != nullptr) {
    hit->weight_q = static_cast<std::uint16_t>(std::min<int>(65535, hit->weight_q + wq));
  } else {
    LabelVote* weakest = votes[0].weight_q <= votes[1].weight_q ? &votes[0] : &votes[1];
    if (weakest->weight_q > wq) {
      weakest->weight_q = static_cast<std::uint16_t>(weakest->weight_q - wq);
    } else {
      weakest->weight_q = static_cast<std::uint16_t>(std::max(1, wq - weakest->weight_q));
      weakest->label = l;
    }
  }
}

}  // namespace

// Label votes of a frame whose geometry is already in the map (segmentation finished after its keyframe was
// integrated): the same pixel-voxel correspondences and weights as integrate()'s label votes, from the frame's own
// depth and pose, into the active blocks only (nothing is allocated; samples whose block left the window or was
// never allocated are counted). Blocks whose most likely label changed in some voxel are marked dirty.
bool SemanticTsdf::integrate_label_votes(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera) {
  if (!ready_ || !frame.has_labels || !frame.intrinsics.valid() || !world_T_camera.matrix().allFinite()) return false;
  ++label_stamp_;
  ++counters_.label_frames;
  touched_.clear();
  const messages::CameraIntrinsics& in = frame.intrinsics;
  const float min_m = static_cast<float>(config_.min_range_m), max_m = static_cast<float>(config_.max_range_m);
  const float trunc = static_cast<float>(config_.voxel_size_m * config_.truncation_voxels);
  const double block_m = config_.voxel_size_m * kBlockSide;
  const Eigen::Vector3d robot_m = world_T_camera.translation();
  const int stride =
      std::max(1, static_cast<int>(config_.voxel_size_m * std::min(in.fx, std::abs(in.fy)) / config_.max_range_m));
  const Eigen::Matrix3d R = world_T_camera.linear();
  for (int v = 0; v < in.height; v += stride) {
    for (int u = 0; u < in.width; u += stride) {
      const float d = frame.depth_m[static_cast<std::size_t>(v * in.width + u)];
      if (!valid_depth(d, min_m, max_m)) continue;
      const Eigen::Vector3d dir = R * Eigen::Vector3d((u - in.cx) / in.fx, (v - in.cy) / in.fy, 1.0);
      for (int k = -1; k <= 1; ++k) {
        const Eigen::Vector3d p = robot_m + dir * (d + k * trunc);
        const memory::Index3 bi{static_cast<std::int32_t>(std::floor(p.x() / block_m)),
                                static_cast<std::int32_t>(std::floor(p.y() / block_m)),
                                static_cast<std::int32_t>(std::floor(p.z() / block_m))};
        const std::uint32_t* h = block_index_.find(bi);
        if (h == nullptr) {
          ++counters_.label_samples_missed;
          continue;
        }
        Block& b = blocks_[*h];
        if (b.label_stamp != label_stamp_) {
          b.label_stamp = label_stamp_;
          touched_.push_back(*h);
        }
      }
    }
  }
  const Eigen::Isometry3d camera_T_world = world_T_camera.inverse();
  for (std::uint32_t h : touched_)
    if (vote_block(blocks_[h], frame, camera_T_world)) blocks_[h].dirty = true;
  return true;
}

namespace {
// Projects each voxel of a block into the frame (nearest pixel) and calls fn(voxel index, pixel, sdf, weight) for
// those with a valid depth within the truncation: the shared projection of integration and label votes. Full weight
// in front of the surface and up to one voxel behind it, then falling linearly to zero at the truncation distance:
// what lies behind a surface is only guessed.
template <typename Fn>
void for_each_projected_voxel(const Config& config, const memory::Index3& block, const messages::RgbdFrame& frame,
                              const Eigen::Isometry3d& camera_T_world, Fn&& fn) {
  const messages::CameraIntrinsics& in = frame.intrinsics;
  const float voxel = static_cast<float>(config.voxel_size_m);
  const float trunc = voxel * static_cast<float>(config.truncation_voxels);
  const float min_m = static_cast<float>(config.min_range_m), max_m = static_cast<float>(config.max_range_m);
  const float fx = static_cast<float>(in.fx), fy = static_cast<float>(in.fy);
  const float cx = static_cast<float>(in.cx), cy = static_cast<float>(in.cy);
  const Eigen::Vector3d origin((block.x * kBlockSide + 0.5) * config.voxel_size_m,
                               (block.y * kBlockSide + 0.5) * config.voxel_size_m,
                               (block.z * kBlockSide + 0.5) * config.voxel_size_m);
  const Eigen::Vector3f p0 = (camera_T_world * origin).cast<float>();
  const Eigen::Matrix3f step = (camera_T_world.linear() * config.voxel_size_m).cast<float>();
  int i = 0;
  for (int z = 0; z < kBlockSide; ++z) {
    for (int y = 0; y < kBlockSide; ++y) {
      Eigen::Vector3f p = p0 + step.col(1) * static_cast<float>(y) + step.col(2) * static_cast<float>(z);
      for (int x = 0; x < kBlockSide; ++x, ++i, p += step.col(0)) {
        if (p.z() < min_m || p.z() > max_m + trunc) continue;
        const float inv_z = 1.0f / p.z();
        const int u = static_cast<int>(std::lround(fx * p.x() * inv_z + cx));
        const int v = static_cast<int>(std::lround(fy * p.y() * inv_z + cy));
        if (u < 0 || v < 0 || u >= in.width || v >= in.height) continue;
        const std::size_t pix = static_cast<std::size_t>(v * in.width + u);
        const float d = frame.depth_m[pix];
        if (!valid_depth(d, min_m, max_m)) continue;
        const float sdf = d - p.z();
        if (sdf < -trunc) continue;
        const float w = sdf >= -voxel ? 1.0f : (trunc + sdf) / (trunc - voxel);
        if (w <= 0.0f) continue;
        fn(i, pix, sdf, w);
      }
    }
  }
}
}  // namespace

bool SemanticTsdf::vote_block(Block& block, const messages::RgbdFrame& frame, const Eigen::Isometry3d& camera_T_world) {
  bool changed = false;
  for_each_projected_voxel(config_, block.index, frame, camera_T_world, [&](int i, std::size_t pix, float, float w) {
    Voxel& vx = block.voxels[i];
    const semantics::Label before = best_label(vx);
    add_label_vote(vx, frame.labels[pix], w);
    changed |= best_label(vx) != before;
  });
  return changed;
}

void SemanticTsdf::integrate_range(const messages::RgbdFrame& frame, const Eigen::Isometry3d& camera_T_world,
                                   std::uint32_t begin, std::uint32_t end) {
  for (std::uint32_t i = begin; i < end; ++i) integrate_block(blocks_[touched_[i]], frame, camera_T_world);
}

void SemanticTsdf::integrate_block(Block& block, const messages::RgbdFrame& frame,
                                   const Eigen::Isometry3d& camera_T_world) {
  const float voxel = static_cast<float>(config_.voxel_size_m);
  const float trunc = voxel * static_cast<float>(config_.truncation_voxels);
  const float max_w = static_cast<float>(config_.max_weight);
  const float inv_trunc_q = kSdfQuant / trunc;
  const bool labels = config_.integrate_labels && frame.has_labels;
  for_each_projected_voxel(config_, block.index, frame, camera_T_world, [&](int i, std::size_t pix, float sdf, float w) {
    sdf = std::min(sdf, trunc);
    Voxel& vx = block.voxels[i];
    const float w_old = static_cast<float>(vx.weight_q) / kWeightScale;
    const float w_sum = w_old + w;
    const float sdf_old = static_cast<float>(vx.sdf_q) / inv_trunc_q;
    const float sdf_new = (sdf_old * w_old + sdf * w) / w_sum;
    vx.sdf_q = static_cast<std::int16_t>(std::lround(std::max(-1.0f, std::min(1.0f, sdf_new / trunc)) * kSdfQuant));
    vx.weight_q = static_cast<std::uint16_t>(std::lround(std::min(w_sum, max_w) * kWeightScale));
    const std::uint8_t* c = &frame.rgb[3 * pix];
    for (int k = 0; k < 3; ++k)
      vx.rgb[k] = static_cast<std::uint8_t>(std::lround((vx.rgb[k] * w_old + c[k] * w) / w_sum));
    if (labels) add_label_vote(vx, frame.labels[pix], w);
  });
}

}  // namespace qsg::reconstruction
