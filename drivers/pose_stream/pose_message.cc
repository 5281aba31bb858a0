// Encoding and checking of pose-stream datagrams, and the CRC-32 that protects them.
#include "drivers/pose_stream/pose_message.h"

#include <array>
#include <cmath>
#include <cstring>

namespace qsg::pose_stream {
namespace {

// Byte-at-a-time table, computed by the compiler: 1 KiB of rodata instead of 8 shifts per byte at run time.
constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int bit = 0; bit < 8; ++bit) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    table[i] = c;
  }
  return table;
}
constexpr std::array<std::uint32_t, 256> kCrcTable = make_crc_table();

// Little-endian field writers and readers: shifts, so the host's byte order never leaks onto the wire.
void put_u16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_u64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_f64(std::uint8_t* p, double v) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);  // IEEE-754 binary64 bit pattern of one scalar
  put_u64(p, bits);
}

std::uint16_t get_u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t get_u32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}
std::uint64_t get_u64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}
double get_f64(const std::uint8_t* p) {
  const std::uint64_t bits = get_u64(p);
  double v = 0.0;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

}  // namespace

const char* to_string(DecodeStatus status) {
  switch (status) {
    case DecodeStatus::kOk: return "ok";
    case DecodeStatus::kWrongSize: return "wrong size";
    case DecodeStatus::kBadMagic: return "bad magic";
    case DecodeStatus::kUnsupportedVersion: return "unsupported version";
    case DecodeStatus::kBadCrc: return "bad crc";
    case DecodeStatus::kBadFrameId: return "bad frame id";
    case DecodeStatus::kNonFinite: return "non-finite number";
    case DecodeStatus::kNonUnitQuaternion: return "non-unit quaternion";
    case DecodeStatus::kBadCovariance: return "bad covariance";
  }
  return "?";
}

std::uint32_t crc32(const std::uint8_t* data, std::size_t size) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) c = kCrcTable[(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

bool encode_pose_message(const messages::OdometrySample& sample, const char* frame_id, std::uint8_t* out,
                         std::uint32_t message_flags) {
  const std::size_t id_length = frame_id == nullptr ? 0 : strnlen(frame_id, kFrameIdBytes);
  if (id_length >= kFrameIdBytes) return false;

  std::memcpy(out + kOffsetMagic, kPoseMessageMagic, sizeof kPoseMessageMagic);
  put_u16(out + kOffsetVersion, kPoseMessageVersion);
  put_u16(out + kOffsetMessageSize, static_cast<std::uint16_t>(kPoseMessageSize));
  put_u64(out + kOffsetSequence, sample.sequence);
  put_u64(out + kOffsetSampleTime, static_cast<std::uint64_t>(sample.sample_time_ns));
  std::memset(out + kOffsetFrameId, 0, kFrameIdBytes);
  if (id_length > 0) std::memcpy(out + kOffsetFrameId, frame_id, id_length);
  for (int i = 0; i < 3; ++i) put_f64(out + kOffsetPosition + 8 * i, sample.world_t_body_m[i]);
  const Eigen::Quaterniond& q = sample.world_R_body;
  const double xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
  for (int i = 0; i < 4; ++i) put_f64(out + kOffsetOrientation + 8 * i, xyzw[i]);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) put_f64(out + kOffsetCovariance + 8 * (6 * r + c), sample.covariance(r, c));
  }
  put_u32(out + kOffsetFlags, message_flags);
  put_u32(out + kOffsetCrc, crc32(out, kOffsetCrc));
  return true;
}

DecodeStatus decode_pose_message(const std::uint8_t* data, std::size_t size, messages::OdometrySample* out,
                                 char frame_id[kFrameIdBytes], std::uint32_t* message_flags) {
  // Magic and version first, so a datagram of a later version is reported as such rather than as a wrong size.
  if (size < kPoseMessageHeaderBytes) return DecodeStatus::kWrongSize;
  if (std::memcmp(data + kOffsetMagic, kPoseMessageMagic, sizeof kPoseMessageMagic) != 0) {
    return DecodeStatus::kBadMagic;
  }
  if (get_u16(data + kOffsetVersion) != kPoseMessageVersion) return DecodeStatus::kUnsupportedVersion;
  if (size != kPoseMessageSize || get_u16(data + kOffsetMessageSize) != kPoseMessageSize) {
    return DecodeStatus::kWrongSize;
  }
  if (get_u32(data + kOffsetCrc) != crc32(data, kOffsetCrc)) return DecodeStatus::kBadCrc;

  const char* id = reinterpret_cast<const char*>(data + kOffsetFrameId);
  if (strnlen(id, kFrameIdBytes) >= kFrameIdBytes) return DecodeStatus::kBadFrameId;

  double t[3];
  double q[4];  // x y z w
  for (int i = 0; i < 3; ++i) t[i] = get_f64(data + kOffsetPosition + 8 * i);
  for (int i = 0; i < 4; ++i) q[i] = get_f64(data + kOffsetOrientation + 8 * i);
  for (double v : t) {
    if (!std::isfinite(v)) return DecodeStatus::kNonFinite;
  }
  for (double v : q) {
    if (!std::isfinite(v)) return DecodeStatus::kNonFinite;
  }
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(std::fabs(norm - 1.0) <= kQuaternionNormTolerance)) return DecodeStatus::kNonUnitQuaternion;

  Eigen::Matrix<double, 6, 6> covariance;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      const double v = get_f64(data + kOffsetCovariance + 8 * (6 * r + c));
      if (!std::isfinite(v) || (r == c && v < 0.0)) return DecodeStatus::kBadCovariance;
      covariance(r, c) = v;
    }
  }

  out->sequence = get_u64(data + kOffsetSequence);
  out->sample_time_ns = static_cast<std::int64_t>(get_u64(data + kOffsetSampleTime));
  out->world_t_body_m = Eigen::Vector3d(t[0], t[1], t[2]);
  // Leave a unit quaternion bit for bit; a float32 source's rounding (well inside the tolerance) is taken out.
  const double scale = std::fabs(norm - 1.0) <= 1e-9 ? 1.0 : 1.0 / norm;
  out->world_R_body = Eigen::Quaterniond(q[3] * scale, q[0] * scale, q[1] * scale, q[2] * scale);
  out->covariance = covariance;
  std::memcpy(frame_id, id, kFrameIdBytes);
  if (message_flags != nullptr) *message_flags = get_u32(data + kOffsetFlags);
  return DecodeStatus::kOk;
}

}  // namespace qsg::pose_stream
