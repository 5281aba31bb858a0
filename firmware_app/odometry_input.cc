// The app's odometry input: source construction, pacing on the loop clock, silence faults, frame poses.
#include "firmware_app/odometry_input.h"

#include <cinttypes>

#include "drivers/pose_stream/pose_stream_source.h"
#include "firmware_app/fault_injection.h"

namespace qsg::app {

OdometryInput::OdometryInput() = default;
OdometryInput::~OdometryInput() = default;

bool OdometryInput::init(const AppConfig& config, const replay::Trajectory& ground_truth,
                         const Eigen::Isometry3d& body_T_camera, std::uint32_t buffer_depth, std::int64_t max_wait_ns,
                         std::string* error) {
  const AppConfig::Odometry& o = config.odometry;
  kind_ = o.source;
  if (kind_ == OdometrySourceKind::kAuto)
    kind_ = config.driver == Driver::kSim      ? OdometrySourceKind::kSimDrift
            : config.driver == Driver::kReplay ? OdometrySourceKind::kGroundTruth
                                               : OdometrySourceKind::kStatic;
  if ((kind_ == OdometrySourceKind::kSimDrift || kind_ == OdometrySourceKind::kGroundTruth) && ground_truth.empty())
    return *error = std::string("odometry: source ") + to_string(kind_) + " needs a ground-truth trajectory, and " +
                    to_string(config.driver) + " has none (replay: groundtruth.txt, trajectory.log or pose.txt)",
           false;
  body_T_camera_ = body_T_camera;
  max_wait_ns_ = max_wait_ns;
  silence_fault_ns_ = static_cast<std::int64_t>(o.silence_fault_s * 1e9);
  switch (kind_) {
    case OdometrySourceKind::kSimDrift: {
      sim::DriftingOdometry::Config dc;
      dc.translation_sigma_m_per_sqrt_m = o.translation_sigma_m_per_sqrt_m;
      dc.yaw_sigma_rad_per_sqrt_m = o.yaw_sigma_rad_per_sqrt_m;
      dc.scale_bias = o.scale_bias;
      dc.yaw_bias_rad_per_m = o.yaw_bias_rad_per_m;
      dc.seed = o.seed;
      drift_ = std::make_unique<sim::DriftingOdometry>(ground_truth, dc);
      source_ = drift_.get();
      paced_ = true;
      break;
    }
    case OdometrySourceKind::kGroundTruth:
      trajectory_ = std::make_unique<replay::TrajectoryOdometry>(ground_truth, replay::TrajectoryOdometry::Config{},
                                                                 "ground_truth");
      source_ = trajectory_.get();
      paced_ = true;
      break;
    case OdometrySourceKind::kTum: {
      replay::Trajectory estimate;
      replay::TumSkipped skipped;
      if (!replay::read_tum_trajectory_skipping(o.tum_path, &estimate, &skipped, error))
        return *error = "odometry: " + *error, false;
      if (estimate.empty()) {
        return *error = "odometry: " + o.tum_path + " holds no valid pose" +
                        (skipped.lines > 0 ? " (" + std::to_string(skipped.lines) + " malformed lines, the first: " +
                                                 skipped.first_reason + ")"
                                           : std::string()),
               false;
      }
      counters_.file_lines_skipped = skipped.lines;
      if (skipped.lines > 0)
        std::fprintf(stderr, "qsg_app: odometry: skipped %zu malformed line(s) of the TUM estimate; the first: %s\n",
                     skipped.lines, skipped.first_reason.c_str());
      trajectory_ = std::make_unique<replay::TrajectoryOdometry>(std::move(estimate), replay::TrajectoryOdometry::Config{},
                                                                 "tum_estimate");
      source_ = trajectory_.get();
      paced_ = true;
      break;
    }
    case OdometrySourceKind::kStream: {
      pose_stream::PoseStreamSource::Config sc;
      sc.transport = o.stream_transport;
      sc.bind_address = o.stream_bind_address;
      sc.port = o.stream_port;
      sc.unix_path = o.stream_unix_path;
      stream_ = std::make_unique<pose_stream::PoseStreamSource>();
      if (!stream_->open(sc, error)) return *error = "odometry stream: " + *error, false;
      source_ = stream_.get();
      paced_ = false;
      break;
    }
    case OdometrySourceKind::kStatic:
    case OdometrySourceKind::kAuto:
      source_ = nullptr;
      break;
  }
  if (source_ != nullptr) source_name_ = source_->name();
  if (faults_ != nullptr) source_ = faults_->wrap_odometry(source_);
  return buffer_.init(buffer_depth, o.buffer, error);
}

const char* OdometryInput::source_name() const { return source_name_; }

const drivers::DriverCounters* OdometryInput::driver_counters() const {
  return source_ != nullptr ? &source_->counters() : nullptr;
}

int OdometryInput::stream_port() const { return stream_ != nullptr ? stream_->port() : 0; }

void OdometryInput::poll(std::int64_t now_loop_ns, bool have_offset, std::int64_t data_offset_ns) {
  if (source_ == nullptr || ended_) return;
  // Bounded per call: a burst (a sender that fell behind) is read over the next ticks.
  constexpr int kMaxReadsPerPoll = 256;
  for (int k = 0; k < kMaxReadsPerPoll; ++k) {
    if (!have_pending_) {
      const drivers::ReadStatus s = source_->read(pending_, 0);
      if (s == drivers::ReadStatus::kEndOfStream) {
        ended_ = true;
        return;
      }
      if (s == drivers::ReadStatus::kBadFrame) {
        ++counters_.source_bad;
        continue;
      }
      if (s == drivers::ReadStatus::kDisconnected) ++counters_.disconnects;
      if (s != drivers::ReadStatus::kOk) break;  // nothing more now (timeout or gone): try on the next tick
      ++counters_.samples_read;
      have_pending_ = true;
    }
    if (paced_ && (!have_offset || pending_.sample_time_ns + data_offset_ns > now_loop_ns)) break;  // not its time
    buffer_.push(pending_);
    have_pending_ = false;
    last_sample_loop_ns_ = now_loop_ns;
    silent_ = false;
  }
  // A source that goes quiet is a fault to see, not a reason to stop: the map keeps its last state. A live
  // stream that has sent nothing since the first poll is silent too (a paced source publishes on its own data's
  // clock, so before its first sample it is not late).
  if (first_poll_loop_ns_ < 0) first_poll_loop_ns_ = now_loop_ns;
  const std::int64_t since = last_sample_loop_ns_ >= 0 ? last_sample_loop_ns_ : paced_ ? -1 : first_poll_loop_ns_;
  if (since >= 0 && !silent_ && now_loop_ns - since > silence_fault_ns_) {
    silent_ = true;
    ++counters_.silences;
    std::fprintf(stderr, "qsg_app: odometry: %s silent for %.1f s%s (fault %" PRIu64 "); frames wait for poses\n",
                 source_name(), 1e-9 * static_cast<double>(now_loop_ns - since),
                 last_sample_loop_ns_ < 0 ? ", nothing received yet" : "", counters_.silences);
  }
}

FramePose OdometryInput::frame_pose(std::int64_t sample_time_ns, std::int64_t waited_ns,
                                    Eigen::Isometry3d* world_T_camera, Eigen::Matrix<double, 6, 1>* variance) {
  if (source_ == nullptr) {
    variance->setZero();
    *world_T_camera = body_T_camera_;  // static: the body stands at the origin
    ++counters_.frames_posed;
    return FramePose::kReady;
  }
  Eigen::Isometry3d world_T_body;
  switch (buffer_.lookup(sample_time_ns, &world_T_body, variance)) {
    case runtime::PoseLookup::kOk:
      *world_T_camera = world_T_body * body_T_camera_;
      ++counters_.frames_posed;
      return FramePose::kReady;
    case runtime::PoseLookup::kEmpty:
    case runtime::PoseLookup::kNotYet:
      if (!ended_ && waited_ns < max_wait_ns_) {
        if (waited_ns == 0) ++counters_.frames_waited;
        return FramePose::kWait;
      }
      ++counters_.frames_no_pose;
      return FramePose::kDrop;
    case runtime::PoseLookup::kTooOld:
      ++counters_.frames_pose_too_old;
      return FramePose::kDrop;
    case runtime::PoseLookup::kInGap:
      ++counters_.frames_in_gap;
      return FramePose::kDrop;
  }
  return FramePose::kDrop;
}

void OdometryInput::print_report(std::FILE* out) const {
  const OdometryCounters& c = counters_;
  std::fprintf(out,
               "odometry: source %s (%s): %" PRIu64 " samples read, %" PRIu64 " malformed, %" PRIu64
               " file lines skipped; frames posed %" PRIu64
               ", waited %" PRIu64 ", dropped %" PRIu64 " (no pose in time %" PRIu64 ", older than the buffer %" PRIu64
               ", in a gap %" PRIu64 "); %" PRIu64 " silences, %" PRIu64 " disconnected reads\n",
               to_string(kind_), source_name(), c.samples_read, c.source_bad, c.file_lines_skipped, c.frames_posed,
               c.frames_waited,
               c.frames_dropped(), c.frames_no_pose, c.frames_pose_too_old, c.frames_in_gap, c.silences, c.disconnects);
  buffer_.counters().print(out);
  buffer_.stats().print(out);
  if (const drivers::DriverCounters* d = driver_counters())
    std::fprintf(out,
                 "odometry driver %s: delivered=%" PRIu64 " dropped=%" PRIu64 " stalls=%" PRIu64
                 " timestamps_backwards=%" PRIu64 " bad=%" PRIu64 "\n",
                 source_name(), d->delivered, d->dropped, d->stalls, d->timestamps_backwards, d->bad_frames);
}

}  // namespace qsg::app
