// Pose-stream message: the CRC check value, the byte layout, a bit-exact round trip, one status per malformed case,
// and a seeded fuzz loop (random strings, single-byte mutations) that never crashes nor accepts a corrupt message.
#include "drivers/pose_stream/pose_message.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace qsg::pose_stream {
namespace {

using Bytes = std::vector<std::uint8_t>;

messages::OdometrySample make_sample() {
  messages::OdometrySample s;
  s.sequence = 0x0102030405060708ull;
  s.sample_time_ns = 1'700'000'000'123'456'789;
  s.world_t_body_m = Eigen::Vector3d(1.25, -3.0e-7, 12345.678901234);
  s.world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.5, 1.0).normalized()));
  Eigen::Matrix<double, 6, 6> a;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) a(r, c) = 0.01 * std::sin(1.0 + r * 6 + c);
  }
  s.covariance = a * a.transpose() + 1e-6 * Eigen::Matrix<double, 6, 6>::Identity();
  return s;
}

Bytes encode(const messages::OdometrySample& s, const char* frame_id = "odom", std::uint32_t flags = 0) {
  Bytes b(kPoseMessageSize);
  EXPECT_TRUE(encode_pose_message(s, frame_id, b.data(), flags));
  return b;
}

// Recomputes the CRC after a deliberate corruption, so the check under test is the one that fires.
void reseal(Bytes& b) {
  const std::uint32_t crc = crc32(b.data(), kOffsetCrc);
  for (int i = 0; i < 4; ++i) b[kOffsetCrc + i] = static_cast<std::uint8_t>(crc >> (8 * i));
}

void put_double(Bytes& b, std::size_t offset, double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, 8);
  for (int i = 0; i < 8; ++i) b[offset + i] = static_cast<std::uint8_t>(bits >> (8 * i));
}

DecodeStatus decode(const Bytes& b) {
  messages::OdometrySample s;
  char frame_id[kFrameIdBytes];
  return decode_pose_message(b.data(), b.size(), &s, frame_id);
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(PoseMessageTest, Crc32MatchesTheStandardCheckValue) {
  const char* text = "123456789";
  EXPECT_EQ(crc32(reinterpret_cast<const std::uint8_t*>(text), 9), 0xCBF43926u);
  EXPECT_EQ(crc32(nullptr, 0), 0u);
}

TEST(PoseMessageTest, LayoutIsLittleEndianAtTheDocumentedOffsets) {
  static_assert(kPoseMessageSize == 392);
  static_assert(kOffsetCovariance + 36 * 8 == kOffsetFlags && kOffsetFlags + 4 == kOffsetCrc);
  messages::OdometrySample s = make_sample();
  s.world_t_body_m.x() = 1.0;  // 0x3FF0000000000000
  const Bytes b = encode(s, "odom", 0xA1B2C3D4u);
  EXPECT_EQ(std::memcmp(b.data(), "QSGP", 4), 0);
  EXPECT_EQ(b[4], 1);
  EXPECT_EQ(b[5], 0);
  EXPECT_EQ(b[6], 392 & 0xFF);
  EXPECT_EQ(b[7], 392 >> 8);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(b[kOffsetSequence + i], 8 - i);
  EXPECT_EQ(std::memcmp(b.data() + kOffsetFrameId, "odom\0\0\0\0\0\0\0\0\0\0\0\0", 16), 0);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(b[kOffsetPosition + i], 0);
  EXPECT_EQ(b[kOffsetPosition + 6], 0xF0);
  EXPECT_EQ(b[kOffsetPosition + 7], 0x3F);
  EXPECT_EQ(b[kOffsetFlags], 0xD4);
  EXPECT_EQ(b[kOffsetFlags + 3], 0xA1);
  const std::uint32_t crc = crc32(b.data(), kOffsetCrc);
  EXPECT_EQ(b[kOffsetCrc], crc & 0xFF);
  EXPECT_EQ(b[kOffsetCrc + 3], crc >> 24);
}

TEST(PoseMessageTest, RoundTripIsBitExact) {
  const messages::OdometrySample in = make_sample();
  const Bytes b = encode(in, "vio_camera_0", kPoseMessageEstimatorReset);
  messages::OdometrySample out;
  out.flags = 77;
  out.publish_time_ns = 99;
  char frame_id[kFrameIdBytes];
  std::uint32_t flags = 0;
  ASSERT_EQ(decode_pose_message(b.data(), b.size(), &out, frame_id, &flags), DecodeStatus::kOk);
  EXPECT_EQ(out.sequence, in.sequence);
  EXPECT_EQ(out.sample_time_ns, in.sample_time_ns);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(same_bits(out.world_t_body_m[i], in.world_t_body_m[i]));
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(same_bits(out.world_R_body.coeffs()[i], in.world_R_body.coeffs()[i]));
  for (int i = 0; i < 36; ++i) EXPECT_TRUE(same_bits(out.covariance.data()[i], in.covariance.data()[i]));
  EXPECT_STREQ(frame_id, "vio_camera_0");
  EXPECT_EQ(flags, kPoseMessageEstimatorReset);
  EXPECT_EQ(out.flags, 77u);  // receiver-side fields are not on the wire
  EXPECT_EQ(out.publish_time_ns, 99);

  // Negative times and the extremes of the integer fields survive too.
  messages::OdometrySample edge = in;
  edge.sequence = std::numeric_limits<std::uint64_t>::max();
  edge.sample_time_ns = std::numeric_limits<std::int64_t>::min();
  ASSERT_EQ(decode_pose_message(encode(edge).data(), kPoseMessageSize, &out, frame_id), DecodeStatus::kOk);
  EXPECT_EQ(out.sequence, edge.sequence);
  EXPECT_EQ(out.sample_time_ns, edge.sample_time_ns);
}

TEST(PoseMessageTest, FrameIdMustFitWithItsTerminator) {
  Bytes b(kPoseMessageSize, 0xEE);
  EXPECT_FALSE(encode_pose_message(make_sample(), "sixteen_chars_xx", b.data()));
  EXPECT_EQ(b[0], 0xEE);  // nothing written
  EXPECT_TRUE(encode_pose_message(make_sample(), "fifteen_chars_x", b.data()));
  EXPECT_TRUE(encode_pose_message(make_sample(), "", b.data()));

  Bytes bad = encode(make_sample());
  std::memset(bad.data() + kOffsetFrameId, 'x', kFrameIdBytes);
  reseal(bad);
  EXPECT_EQ(decode(bad), DecodeStatus::kBadFrameId);
}

TEST(PoseMessageTest, EveryLengthButTheRightOneIsWrongSize) {
  Bytes b = encode(make_sample());
  for (std::size_t n = 0; n < kPoseMessageSize; ++n) {
    const Bytes prefix(b.begin(), b.begin() + static_cast<long>(n));
    EXPECT_EQ(decode(prefix), DecodeStatus::kWrongSize) << n;
  }
  Bytes longer = b;
  longer.push_back(0);
  EXPECT_EQ(decode(longer), DecodeStatus::kWrongSize);
  longer.resize(1000, 0);
  EXPECT_EQ(decode(longer), DecodeStatus::kWrongSize);
  // The size field must agree with the datagram.
  b[kOffsetMessageSize] = 0x89;
  reseal(b);
  EXPECT_EQ(decode(b), DecodeStatus::kWrongSize);
}

TEST(PoseMessageTest, HeaderFieldsHaveTheirOwnStatus) {
  Bytes magic = encode(make_sample());
  magic[2] = 'X';
  EXPECT_EQ(decode(magic), DecodeStatus::kBadMagic);

  Bytes version = encode(make_sample());
  version[kOffsetVersion] = 2;
  EXPECT_EQ(decode(version), DecodeStatus::kUnsupportedVersion);
  // A later version of another size is named by its version, not its size.
  version.resize(500, 0);
  EXPECT_EQ(decode(version), DecodeStatus::kUnsupportedVersion);
  version[kOffsetVersion] = 0;
  EXPECT_EQ(decode(version), DecodeStatus::kUnsupportedVersion);
}

TEST(PoseMessageTest, AnyFlippedBitIsCaught) {
  const Bytes good = encode(make_sample());
  for (std::size_t byte = 0; byte < kPoseMessageSize; ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      Bytes b = good;
      b[byte] ^= static_cast<std::uint8_t>(1u << bit);
      const DecodeStatus status = decode(b);
      if (byte < kOffsetVersion) {
        EXPECT_EQ(status, DecodeStatus::kBadMagic) << byte;
      } else if (byte < kOffsetMessageSize) {
        EXPECT_EQ(status, DecodeStatus::kUnsupportedVersion) << byte;
      } else if (byte < kOffsetSequence) {
        EXPECT_EQ(status, DecodeStatus::kWrongSize) << byte;
      } else {
        EXPECT_EQ(status, DecodeStatus::kBadCrc) << byte << " bit " << bit;
      }
    }
  }
}

TEST(PoseMessageTest, NonFiniteNumbersAreRejected) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    Bytes b = encode(make_sample());
    put_double(b, kOffsetPosition + 8 * i, i == 1 ? -inf : nan);
    reseal(b);
    EXPECT_EQ(decode(b), DecodeStatus::kNonFinite) << "position " << i;
  }
  for (int i = 0; i < 4; ++i) {
    Bytes b = encode(make_sample());
    put_double(b, kOffsetOrientation + 8 * i, i == 2 ? inf : nan);
    reseal(b);
    EXPECT_EQ(decode(b), DecodeStatus::kNonFinite) << "orientation " << i;
  }
}

TEST(PoseMessageTest, QuaternionMustBeUnitWithinTolerance) {
  messages::OdometrySample s = make_sample();
  s.world_R_body.coeffs() *= 1.002;
  EXPECT_EQ(decode(encode(s)), DecodeStatus::kNonUnitQuaternion);
  s.world_R_body.coeffs() *= 0.0;
  EXPECT_EQ(decode(encode(s)), DecodeStatus::kNonUnitQuaternion);

  // Within the tolerance (a float32 source, say): accepted and normalised.
  s = make_sample();
  s.world_R_body.coeffs() *= 1.0005;
  messages::OdometrySample out;
  char frame_id[kFrameIdBytes];
  ASSERT_EQ(decode_pose_message(encode(s).data(), kPoseMessageSize, &out, frame_id), DecodeStatus::kOk);
  EXPECT_NEAR(out.world_R_body.norm(), 1.0, 1e-15);
  EXPECT_TRUE(out.world_R_body.isApprox(make_sample().world_R_body, 1e-12));
}

TEST(PoseMessageTest, CovarianceMustBeFiniteWithNonNegativeDiagonal) {
  Bytes nan = encode(make_sample());
  put_double(nan, kOffsetCovariance + 8 * (6 * 1 + 4), std::numeric_limits<double>::quiet_NaN());
  reseal(nan);
  EXPECT_EQ(decode(nan), DecodeStatus::kBadCovariance);

  Bytes negative = encode(make_sample());
  put_double(negative, kOffsetCovariance + 8 * (6 * 5 + 5), -1e-9);
  reseal(negative);
  EXPECT_EQ(decode(negative), DecodeStatus::kBadCovariance);

  // Off the diagonal a negative correlation is fine; a zero diagonal (an exact axis) too.
  messages::OdometrySample s = make_sample();
  s.covariance(0, 1) = s.covariance(1, 0) = -1e-5;
  s.covariance(2, 2) = 0.0;
  EXPECT_EQ(decode(encode(s)), DecodeStatus::kOk);
}

TEST(PoseMessageTest, FailedDecodeLeavesTheOutputsAlone) {
  Bytes b = encode(make_sample());
  b[100] ^= 1;
  messages::OdometrySample out;
  out.sequence = 42;
  char frame_id[kFrameIdBytes] = "keep";
  std::uint32_t flags = 5;
  EXPECT_EQ(decode_pose_message(b.data(), b.size(), &out, frame_id, &flags), DecodeStatus::kBadCrc);
  EXPECT_EQ(out.sequence, 42u);
  EXPECT_STREQ(frame_id, "keep");
  EXPECT_EQ(flags, 5u);
}

TEST(PoseMessageTest, StatusesHaveNames) {
  for (int i = 0; i < kDecodeStatusCount; ++i) {
    EXPECT_STRNE(to_string(static_cast<DecodeStatus>(i)), "?") << i;
  }
}

TEST(PoseMessageTest, FuzzNeverCrashesNorAcceptsCorruption) {
  std::mt19937_64 rng(20240611);
  std::uniform_int_distribution<int> byte(0, 255);
  messages::OdometrySample out;
  char frame_id[kFrameIdBytes];

  // Random strings, some of them starting like a message so the later checks are reached.
  for (int iteration = 0; iteration < 20000; ++iteration) {
    const std::size_t size = (iteration % 3 == 0) ? kPoseMessageSize : rng() % 800;
    Bytes b(size);
    for (auto& v : b) v = static_cast<std::uint8_t>(byte(rng));
    if (iteration % 2 == 0 && size >= kPoseMessageHeaderBytes) {
      std::memcpy(b.data(), "QSGP\x01\x00\x88\x01", kPoseMessageHeaderBytes);
    }
    EXPECT_NE(decode_pose_message(b.data(), b.size(), &out, frame_id), DecodeStatus::kOk) << iteration;
  }

  const Bytes good = encode(make_sample());
  for (int iteration = 0; iteration < 20000; ++iteration) {
    // One byte changed: CRC-32 catches every error burst of up to 32 bits.
    Bytes b = good;
    const std::size_t at = rng() % kPoseMessageSize;
    b[at] = static_cast<std::uint8_t>(b[at] ^ (1 + rng() % 255));
    EXPECT_NE(decode(b), DecodeStatus::kOk) << iteration;

    // Several bytes changed then resealed: whatever decodes must be a usable pose.
    const int changes = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < changes; ++k) b[kOffsetSequence + rng() % (kOffsetCrc - kOffsetSequence)] = byte(rng);
    reseal(b);
    if (decode_pose_message(b.data(), b.size(), &out, frame_id) == DecodeStatus::kOk) {
      EXPECT_TRUE(out.world_t_body_m.allFinite());
      EXPECT_NEAR(out.world_R_body.norm(), 1.0, kQuaternionNormTolerance);
      EXPECT_TRUE(out.covariance.allFinite());
      EXPECT_TRUE((out.covariance.diagonal().array() >= 0.0).all());
      EXPECT_LT(std::strlen(frame_id), kFrameIdBytes);
    }
  }
}

}  // namespace
}  // namespace qsg::pose_stream
