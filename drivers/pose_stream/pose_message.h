// The pose-stream wire format: one fixed-size, little-endian, CRC-protected datagram per odometry pose, written and
// read field by field so the layout never depends on a compiler's struct padding (README.md has the byte table).
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/messages/sensor_types.h"

namespace qsg::pose_stream {

inline constexpr char kPoseMessageMagic[4] = {'Q', 'S', 'G', 'P'};
inline constexpr std::uint16_t kPoseMessageVersion = 1;
inline constexpr std::size_t kFrameIdBytes = 16;  // NUL-padded; at most 15 characters so it stays a C string

// Byte offsets of version 1. Any change to them is a new version (README.md, "Version policy").
inline constexpr std::size_t kOffsetMagic = 0;
inline constexpr std::size_t kOffsetVersion = 4;
inline constexpr std::size_t kOffsetMessageSize = 6;
inline constexpr std::size_t kOffsetSequence = 8;
inline constexpr std::size_t kOffsetSampleTime = 16;
inline constexpr std::size_t kOffsetFrameId = 24;
inline constexpr std::size_t kOffsetPosition = 40;     // 3 float64: x y z (m), world_T_body
inline constexpr std::size_t kOffsetOrientation = 64;  // 4 float64: qx qy qz qw
inline constexpr std::size_t kOffsetCovariance = 96;   // 36 float64, 6x6 row-major, [t (m); r (rad)]
inline constexpr std::size_t kOffsetFlags = 384;
inline constexpr std::size_t kOffsetCrc = 388;         // CRC-32 of bytes [0, kOffsetCrc)
inline constexpr std::size_t kPoseMessageSize = 392;
// The version and size fields sit at the same place in every version, so a receiver can name what it got.
inline constexpr std::size_t kPoseMessageHeaderBytes = 8;

// Bits of the message's flags field. A receiver ignores bits it does not know; senders write them as 0.
enum PoseMessageFlag : std::uint32_t {
  kPoseMessageEstimatorReset = 1u << 0,  // the estimator restarted: this pose does not continue the previous ones
};

// A pose whose quaternion norm is further than this from 1 is rejected.
inline constexpr double kQuaternionNormTolerance = 1e-3;

enum class DecodeStatus : std::uint8_t {
  kOk,
  kWrongSize,           // datagram length (or the size field) is not kPoseMessageSize
  kBadMagic,
  kUnsupportedVersion,
  kBadCrc,
  kBadFrameId,          // not NUL-terminated within its 16 bytes
  kNonFinite,           // position or orientation holds a NaN or an infinity
  kNonUnitQuaternion,   // |norm - 1| > kQuaternionNormTolerance
  kBadCovariance,       // a non-finite entry or a negative diagonal
};
inline constexpr int kDecodeStatusCount = 9;
const char* to_string(DecodeStatus status);

// CRC-32 as zlib, Ethernet and PNG compute it (reflected polynomial 0xEDB88320, initial and final xor 0xFFFFFFFF):
// crc32("123456789") = 0xCBF43926, and Python's zlib.crc32 gives the same value.
std::uint32_t crc32(const std::uint8_t* data, std::size_t size);

// Writes kPoseMessageSize bytes to `out`: the sample's sequence, sample time, pose and covariance (as given: the
// sender keeps it symmetric), `frame_id` and `message_flags` (PoseMessageFlag bits). The sample's own flags and
// publish time are receiver-side and not sent. Returns false, writing nothing, when frame_id has more than 15
// characters.
bool encode_pose_message(const messages::OdometrySample& sample, const char* frame_id, std::uint8_t* out,
                         std::uint32_t message_flags = 0);

// Checks and reads one datagram. On kOk fills the sample's sequence, sample time, pose and covariance (flags and
// publish time are left for the receiver), the NUL-terminated frame id and, when given, the message flags; on any
// other status leaves the outputs untouched. A quaternion within 1e-9 of unit length passes bit for bit; one
// within kQuaternionNormTolerance is normalised. Reads only `size` bytes, whatever they hold; never allocates.
DecodeStatus decode_pose_message(const std::uint8_t* data, std::size_t size, messages::OdometrySample* out,
                                 char frame_id[kFrameIdBytes], std::uint32_t* message_flags = nullptr);

}  // namespace qsg::pose_stream
