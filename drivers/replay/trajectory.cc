// Trajectory file formats and exact trajectory playback.
#include "drivers/replay/trajectory.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <fstream>

#include "drivers/replay/text_parse.h"

namespace qsg::replay {
namespace {

// Parses fields [first, first+n) as doubles; names the failing field in the error.
bool parse_numbers(const std::string& path, const TextLine& line, std::size_t first, std::size_t n, double* out,
                   std::string* error) {
  for (std::size_t i = 0; i < n; ++i) {
    if (!parse_double(line.fields[first + i], &out[i])) {
      if (error) {
        *error = error_at(path, line.line_number,
                          "field " + std::to_string(first + i + 1) + " '" + line.fields[first + i] +
                              "' is not a finite number");
      }
      return false;
    }
  }
  return true;
}

// Normalises a file quaternion; rejects one far from unit length (a corrupted or mis-ordered line).
bool make_unit_quaternion(double qx, double qy, double qz, double qw, Eigen::Quaterniond* q) {
  const double norm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
  if (!(std::fabs(norm - 1.0) < 1e-2)) return false;
  *q = Eigen::Quaterniond(qw / norm, qx / norm, qy / norm, qz / norm);
  return true;
}

}  // namespace

Eigen::Isometry3d StampedPose::world_T_body() const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = world_R_body.toRotationMatrix();
  t.translation() = world_t_body_m;
  return t;
}

StampedPose StampedPose::from_isometry(std::int64_t time_ns, const Eigen::Isometry3d& world_T_body) {
  StampedPose pose;
  pose.time_ns = time_ns;
  pose.world_t_body_m = world_T_body.translation();
  pose.world_R_body = Eigen::Quaterniond(world_T_body.rotation()).normalized();
  return pose;
}

namespace {

// One TUM line; false with the reason (naming file and line) when it is malformed.
bool parse_tum_line(const std::string& path, const TextLine& line, StampedPose* pose, std::string* error) {
  if (line.fields.size() != 8) {
    if (error) {
      *error = error_at(path, line.line_number,
                        "expected 8 fields 't tx ty tz qx qy qz qw', found " + std::to_string(line.fields.size()));
    }
    return false;
  }
  if (!parse_seconds_to_ns(line.fields[0], &pose->time_ns)) {
    if (error) *error = error_at(path, line.line_number, "timestamp '" + line.fields[0] + "' is not a number");
    return false;
  }
  double v[7];
  if (!parse_numbers(path, line, 1, 7, v, error)) return false;
  pose->world_t_body_m = Eigen::Vector3d(v[0], v[1], v[2]);
  if (!make_unit_quaternion(v[3], v[4], v[5], v[6], &pose->world_R_body)) {
    if (error) *error = error_at(path, line.line_number, "quaternion (qx qy qz qw) is not of unit length");
    return false;
  }
  return true;
}

}  // namespace

namespace {

// Strict (skipped == nullptr): the first malformed line fails the read. Otherwise malformed lines are counted.
bool read_tum(const std::string& path, Trajectory* trajectory, TumSkipped* skipped, std::string* error) {
  trajectory->clear();
  if (skipped != nullptr) *skipped = TumSkipped{};
  std::vector<TextLine> lines;
  if (!read_text_lines(path, &lines, error)) return false;
  trajectory->reserve(lines.size());
  for (const TextLine& line : lines) {
    StampedPose pose;
    std::string why;
    if (parse_tum_line(path, line, &pose, &why)) {
      trajectory->push_back(pose);
      continue;
    }
    if (skipped == nullptr) {
      if (error != nullptr) *error = why;
      return false;
    }
    if (skipped->lines++ == 0) skipped->first_reason = why;
  }
  return true;
}

}  // namespace

bool read_tum_trajectory(const std::string& path, Trajectory* trajectory, std::string* error) {
  return read_tum(path, trajectory, nullptr, error);
}

bool read_tum_trajectory_skipping(const std::string& path, Trajectory* trajectory, TumSkipped* skipped,
                                  std::string* error) {
  return read_tum(path, trajectory, skipped, error);
}

std::string format_tum_pose(const StampedPose& pose) {
  char buffer[256];
  const Eigen::Quaterniond& q = pose.world_R_body;
  std::snprintf(buffer, sizeof(buffer), " %.9f %.9f %.9f %.9f %.9f %.9f %.9f", pose.world_t_body_m.x(),
                pose.world_t_body_m.y(), pose.world_t_body_m.z(), q.x(), q.y(), q.z(), q.w());
  return format_ns_as_seconds(pose.time_ns) + buffer;
}

bool write_tum_trajectory(const std::string& path, const Trajectory& trajectory, std::string* error) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) {
    if (error) *error = path + ": cannot create";
    return false;
  }
  out << "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n";
  for (const StampedPose& pose : trajectory) out << format_tum_pose(pose) << '\n';
  out.flush();
  if (!out) {
    if (error) *error = path + ": write failed";
    return false;
  }
  return true;
}

bool read_redwood_log(const std::string& path, std::vector<RedwoodLogEntry>* entries, std::string* error) {
  entries->clear();
  std::vector<TextLine> lines;
  if (!read_text_lines(path, &lines, error)) return false;
  std::size_t i = 0;
  while (i < lines.size()) {
    const TextLine& header = lines[i];
    RedwoodLogEntry entry;
    entry.line_number = header.line_number;
    bool ok = header.fields.size() == 3;
    for (std::size_t k = 0; ok && k < 3; ++k) ok = parse_int64(header.fields[k], &entry.id[k]);
    if (!ok) {
      if (error) {
        *error = error_at(path, header.line_number,
                          "expected a metadata line of 3 integers 'id id next' (block " +
                              std::to_string(entries->size() + 1) + "), found '" +
                              (header.fields.empty() ? std::string() : header.fields[0]) + " ...' with " +
                              std::to_string(header.fields.size()) + " fields");
      }
      return false;
    }
    for (int row = 0; row < 4; ++row) {
      const std::size_t li = i + 1 + static_cast<std::size_t>(row);
      if (li >= lines.size()) {
        if (error) {
          *error = error_at(path, lines.back().line_number,
                            "file ends inside the matrix of block id " + std::to_string(entry.id[0]) + ": row " +
                                std::to_string(row + 1) + " of 4 is missing");
        }
        return false;
      }
      const TextLine& line = lines[li];
      if (line.fields.size() != 4) {
        if (error) {
          *error = error_at(path, line.line_number,
                            "expected row " + std::to_string(row + 1) + " of the 4x4 matrix of block id " +
                                std::to_string(entry.id[0]) + " (4 numbers), found " +
                                std::to_string(line.fields.size()) + " fields (a missing row?)");
        }
        return false;
      }
      double v[4];
      if (!parse_numbers(path, line, 0, 4, v, error)) return false;
      for (int c = 0; c < 4; ++c) entry.world_T_camera(row, c) = v[c];
    }
    const int last_line = lines[i + 4].line_number;
    const Eigen::RowVector4d last = entry.world_T_camera.row(3);
    if ((last - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
      if (error) *error = error_at(path, last_line, "last matrix row must be '0 0 0 1'");
      return false;
    }
    const Eigen::Matrix3d r = entry.world_T_camera.topLeftCorner<3, 3>();
    if ((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-3 || r.determinant() < 0.0) {
      if (error) {
        *error = error_at(path, header.line_number,
                          "rotation block of matrix id " + std::to_string(entry.id[0]) + " is not a rotation");
      }
      return false;
    }
    entries->push_back(entry);
    i += 5;
  }
  return true;
}

bool read_pose_list(const std::string& path, std::int64_t frame_period_ns, Trajectory* trajectory,
                    std::string* error) {
  trajectory->clear();
  std::vector<TextLine> lines;
  if (!read_text_lines(path, &lines, error)) return false;
  for (const TextLine& line : lines) {
    if (line.fields.size() != 7) {
      if (error) {
        *error = error_at(path, line.line_number,
                          "expected 7 fields 'tx ty tz qx qy qz qw', found " + std::to_string(line.fields.size()));
      }
      return false;
    }
    double v[7];
    if (!parse_numbers(path, line, 0, 7, v, error)) return false;
    StampedPose pose;
    pose.time_ns = static_cast<std::int64_t>(trajectory->size()) * frame_period_ns;
    pose.world_t_body_m = Eigen::Vector3d(v[0], v[1], v[2]);
    if (!make_unit_quaternion(v[3], v[4], v[5], v[6], &pose.world_R_body)) {
      if (error) *error = error_at(path, line.line_number, "quaternion (qx qy qz qw) is not of unit length");
      return false;
    }
    trajectory->push_back(pose);
  }
  return true;
}

bool interpolate_pose(const Trajectory& trajectory, std::int64_t time_ns, std::int64_t max_gap_ns,
                      StampedPose* pose) {
  if (trajectory.empty()) return false;
  const auto after = std::lower_bound(trajectory.begin(), trajectory.end(), time_ns,
                                      [](const StampedPose& p, std::int64_t t) { return p.time_ns < t; });
  if (after == trajectory.end()) return false;
  if (after->time_ns == time_ns) {
    *pose = *after;
    return true;
  }
  if (after == trajectory.begin()) return false;
  const StampedPose& a = *(after - 1);
  const StampedPose& b = *after;
  if (b.time_ns - a.time_ns > max_gap_ns) return false;
  const double s = static_cast<double>(time_ns - a.time_ns) / static_cast<double>(b.time_ns - a.time_ns);
  pose->time_ns = time_ns;
  pose->world_t_body_m = (1.0 - s) * a.world_t_body_m + s * b.world_t_body_m;
  pose->world_R_body = a.world_R_body.slerp(s, b.world_R_body);
  return true;
}

void TrajectoryOdometry::Config::print(std::FILE* out) const {
  std::fprintf(out, "TrajectoryOdometry: publish_latency_ns=%" PRId64 " translation_sigma_m=%g rotation_sigma_rad=%g\n",
               publish_latency_ns, translation_sigma_m, rotation_sigma_rad);
}

TrajectoryOdometry::TrajectoryOdometry(Trajectory trajectory) : trajectory_(std::move(trajectory)) {}

TrajectoryOdometry::TrajectoryOdometry(Trajectory trajectory, const Config& config, const char* name)
    : trajectory_(std::move(trajectory)), config_(config), name_(name) {}

void TrajectoryOdometry::reset(Trajectory trajectory, const char* name) {
  trajectory_ = std::move(trajectory);
  name_ = name;
  counters_ = drivers::DriverCounters{};
  rewind();
}

void TrajectoryOdometry::rewind() {
  next_ = 0;
  have_last_time_ = false;
}

drivers::ReadStatus TrajectoryOdometry::read(messages::OdometrySample& sample, std::int64_t /*timeout_ns*/) {
  if (next_ >= trajectory_.size()) return drivers::ReadStatus::kEndOfStream;
  const StampedPose& pose = trajectory_[next_];
  sample.sequence = next_;
  sample.sample_time_ns = pose.time_ns;
  sample.publish_time_ns = pose.time_ns + config_.publish_latency_ns;
  sample.world_t_body_m = pose.world_t_body_m;
  sample.world_R_body = pose.world_R_body;
  sample.covariance.setZero();
  const double vt = config_.translation_sigma_m * config_.translation_sigma_m;
  const double vr = config_.rotation_sigma_rad * config_.rotation_sigma_rad;
  sample.covariance.diagonal() << vt, vt, vt, vr, vr, vr;
  sample.flags = 0;
  if (have_last_time_ && pose.time_ns <= last_time_ns_) {
    sample.flags |= messages::kFrameTimestampBackwards;
    ++counters_.timestamps_backwards;
  }
  have_last_time_ = true;
  last_time_ns_ = pose.time_ns;
  ++next_;
  ++counters_.delivered;
  return drivers::ReadStatus::kOk;
}

}  // namespace qsg::replay
