// qsg_pose_send: streams a TUM trajectory as pose-stream datagrams over UDP or a Unix socket at the file's own
// pace, to feed PoseStreamSource from a recorded run, or to stand in for a robot's estimator on a desk.
#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "drivers/pose_stream/pose_message.h"
#include "drivers/replay/trajectory.h"

namespace {

using namespace qsg;

struct Options {
  std::string tum_file;
  std::string udp;        // HOST:PORT
  std::string unix_path;
  double speed = 1.0;     // 0: as fast as the socket takes them
  double start_delay_s = 0.0;
  std::string frame_id = "odom";
  double sigma_t_m = 1e-3;
  double sigma_r_rad = 1e-3;
  long repeat_first = 0;
};

void usage() {
  std::printf(
      "usage: qsg_pose_send TUM_FILE (--udp HOST:PORT | --unix PATH) [options]\n"
      "  --udp HOST:PORT      send to an IPv4 host, e.g. 127.0.0.1:47600\n"
      "  --unix PATH          send to a Unix datagram socket\n"
      "  --speed F            play at F times the file's pace (default 1; 0 = no waiting)\n"
      "  --start-delay S      wait S seconds before the first pose (default 0)\n"
      "  --frame-id ID        frame id in every message, at most 15 characters (default odom)\n"
      "  --sigma-t M          translation standard deviation in the covariance (default 0.001)\n"
      "  --sigma-r RAD        rotation standard deviation in the covariance (default 0.001)\n"
      "  --repeat-first N     send the first pose N more times, same sequence number (receivers count duplicates)\n");
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "qsg_pose_send: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    const auto number = [&]() {
      const char* text = value();
      char* end = nullptr;
      const double v = std::strtod(text, &end);
      if (end == text || *end != '\0' || !std::isfinite(v) || v < 0.0) {
        std::fprintf(stderr, "qsg_pose_send: %s: '%s' is not a non-negative number\n", a.c_str(), text);
        std::exit(2);
      }
      return v;
    };
    if (a == "--udp") o.udp = value();
    else if (a == "--unix") o.unix_path = value();
    else if (a == "--speed") o.speed = number();
    else if (a == "--start-delay") o.start_delay_s = number();
    else if (a == "--frame-id") o.frame_id = value();
    else if (a == "--sigma-t") o.sigma_t_m = number();
    else if (a == "--sigma-r") o.sigma_r_rad = number();
    else if (a == "--repeat-first") o.repeat_first = static_cast<long>(number());
    else if (a == "--help" || a == "-h") usage(), std::exit(0);
    else if (!a.empty() && a[0] != '-' && o.tum_file.empty()) o.tum_file = a;
    else {
      std::fprintf(stderr, "qsg_pose_send: unknown argument '%s'\n", a.c_str());
      usage();
      return false;
    }
  }
  if (o.tum_file.empty() || o.udp.empty() == o.unix_path.empty()) {
    std::fprintf(stderr, "qsg_pose_send: needs a TUM file and exactly one of --udp, --unix\n");
    usage();
    return false;
  }
  if (o.frame_id.size() >= pose_stream::kFrameIdBytes) {
    std::fprintf(stderr, "qsg_pose_send: --frame-id '%s' is longer than 15 characters\n", o.frame_id.c_str());
    return false;
  }
  return true;
}

// The destination, resolved once: an IPv4 host (a name is looked up) or a Unix socket path.
struct Destination {
  int fd = -1;
  sockaddr_storage address{};
  socklen_t length = 0;
};

bool open_destination(const Options& o, Destination* d, std::string* error) {
  if (!o.unix_path.empty()) {
    sockaddr_un un{};
    if (o.unix_path.size() >= sizeof un.sun_path) {
      *error = "--unix path '" + o.unix_path + "' is too long for a Unix socket";
      return false;
    }
    un.sun_family = AF_UNIX;
    std::memcpy(un.sun_path, o.unix_path.data(), o.unix_path.size());
    std::memcpy(&d->address, &un, sizeof un);
    d->length = sizeof un;
    d->fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  } else {
    const std::size_t colon = o.udp.rfind(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == o.udp.size()) {
      *error = "--udp '" + o.udp + "' is not HOST:PORT";
      return false;
    }
    const std::string host = o.udp.substr(0, colon);
    const std::string port = o.udp.substr(colon + 1);
    addrinfo hints{};
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_DGRAM;
    addrinfo* found = nullptr;
    const int rc = ::getaddrinfo(host.c_str(), port.c_str(), &hints, &found);
    if (rc != 0 || found == nullptr) {
      *error = "--udp '" + o.udp + "': " + ::gai_strerror(rc);
      return false;
    }
    std::memcpy(&d->address, found->ai_addr, found->ai_addrlen);
    d->length = found->ai_addrlen;
    ::freeaddrinfo(found);
    d->fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  }
  if (d->fd < 0) {
    *error = std::string("socket: ") + std::strerror(errno);
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) return 2;

  replay::Trajectory trajectory;
  std::string error;
  if (!replay::read_tum_trajectory(o.tum_file, &trajectory, &error)) {
    std::fprintf(stderr, "qsg_pose_send: %s\n", error.c_str());
    return 1;
  }
  Destination destination;
  if (!open_destination(o, &destination, &error)) {
    std::fprintf(stderr, "qsg_pose_send: %s\n", error.c_str());
    return 1;
  }

  messages::OdometrySample sample;
  sample.covariance.setZero();
  sample.covariance.diagonal() << Eigen::Vector3d::Constant(o.sigma_t_m * o.sigma_t_m),
      Eigen::Vector3d::Constant(o.sigma_r_rad * o.sigma_r_rad);
  std::uint8_t message[pose_stream::kPoseMessageSize];
  std::uint64_t sent = 0, errors = 0;
  int last_errno = 0;

  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(o.start_delay_s));
  if (o.start_delay_s > 0.0) std::this_thread::sleep_until(start);
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const replay::StampedPose& pose = trajectory[i];
    if (o.speed > 0.0) {
      const double offset_s = 1e-9 * static_cast<double>(pose.time_ns - trajectory.front().time_ns) / o.speed;
      std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(offset_s)));
    }
    sample.sequence = i;
    sample.sample_time_ns = pose.time_ns;
    sample.world_t_body_m = pose.world_t_body_m;
    sample.world_R_body = pose.world_R_body;
    pose_stream::encode_pose_message(sample, o.frame_id.c_str(), message);
    const long copies = i == 0 ? 1 + o.repeat_first : 1;
    for (long k = 0; k < copies; ++k) {
      const ssize_t n = ::sendto(destination.fd, message, sizeof message, 0,
                                 reinterpret_cast<const sockaddr*>(&destination.address), destination.length);
      if (n == static_cast<ssize_t>(sizeof message)) {
        ++sent;
      } else {
        ++errors;
        last_errno = n < 0 ? errno : EMSGSIZE;
      }
    }
  }
  ::close(destination.fd);

  std::printf("qsg_pose_send: %zu poses, %" PRIu64 " messages sent, %" PRIu64 " errors%s%s\n", trajectory.size(),
              sent, errors, errors > 0 ? "; last: " : "", errors > 0 ? std::strerror(last_errno) : "");
  return errors > 0 ? 1 : 0;
}
