// Pose-stream message decoder (drivers/pose_stream/pose_message): any datagram decodes or is refused with a status.
// The first input byte chooses whether the CRC is fixed up over the rest, so the fuzzer also reaches the checks
// behind it (magic, version, frame id, finite pose, unit quaternion, covariance).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "drivers/pose_stream/pose_message.h"

using namespace qsg;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool fix_crc = (data[0] & 1) != 0;
  ++data, --size;
  std::uint8_t message[pose_stream::kPoseMessageSize + 64];
  const std::size_t n = size < sizeof(message) ? size : sizeof(message);
  std::memcpy(message, data, n);
  if (fix_crc && n == pose_stream::kPoseMessageSize) {
    const std::uint32_t crc = pose_stream::crc32(message, pose_stream::kOffsetCrc);
    for (int i = 0; i < 4; ++i) message[pose_stream::kOffsetCrc + i] = static_cast<std::uint8_t>(crc >> (8 * i));
  }
  messages::OdometrySample sample;
  char frame_id[pose_stream::kFrameIdBytes];
  std::uint32_t flags = 0;
  if (pose_stream::decode_pose_message(message, n, &sample, frame_id, &flags) != pose_stream::DecodeStatus::kOk)
    return 0;
  // What passed is usable: a NUL-terminated id, a finite pose with a unit quaternion.
  if (std::memchr(frame_id, '\0', sizeof(frame_id)) == nullptr) std::abort();
  if (!sample.world_t_body_m.allFinite() || std::fabs(sample.world_R_body.norm() - 1.0) > 1e-6) std::abort();
  return 0;
}
