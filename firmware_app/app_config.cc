// Loading and checking the app's configuration.
#include "firmware_app/app_config.h"

#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>

#include "core/params/params_json.h"
#include "firmware_app/app_params.h"

namespace qsg::app {

const char* to_string(Driver d) {
  switch (d) {
    case Driver::kSim: return "sim";
    case Driver::kReplay: return "replay";
    case Driver::kV4l2: return "v4l2";
  }
  return "?";
}

AppConfig::AppConfig() {
  // The simulated quadruped's defaults: a 12-room building, a 320x240 camera at 10 Hz at 0.5 m height.
  building.num_rooms = 12;
  exploration.camera_height_m = 0.5;
  camera.rate_hz = 10.0;
  camera.pitch_rad = 0.15;
  // A listed frame file that is missing is counted and skipped (drivers' missing_files), not a start-up error.
  replay.check_files_at_open = false;
}

bool AppConfig::load(const std::string& path, std::string* error) {
  std::ifstream in(path);
  if (!in) return *error = "config '" + path + "': cannot open", false;
  std::stringstream text;
  text << in.rdbuf();
  // Every key, its type and its range come from the parameter tables (firmware_app/app_params.cc); a new camera
  // size brings its focal length along (sim_camera()).
  std::string why;
  if (!params::load_json(app_schema(), this, text.str(), &why)) return *error = "config '" + path + "': " + why, false;
  camera = sim_camera();
  const std::string bad = check();
  if (!bad.empty()) return *error = "config '" + path + "': " + bad, false;
  return true;
}

sim::SimCamera::Config AppConfig::sim_camera() const {
  sim::SimCamera::Config c = camera;
  const int w = c.intrinsics.width, h = c.intrinsics.height;
  const double f = 525.0 * w / 640.0;
  c.intrinsics = {w, h, f, f, 0.5 * w - 0.5, 0.5 * h - 0.5};
  c.intrinsics = c.effective_intrinsics();  // hfov_deg, when set
  return c;
}

const char* to_string(OdometrySourceKind k) {
  switch (k) {
    case OdometrySourceKind::kAuto: return "auto";
    case OdometrySourceKind::kSimDrift: return "sim_drift";
    case OdometrySourceKind::kGroundTruth: return "ground_truth";
    case OdometrySourceKind::kTum: return "tum";
    case OdometrySourceKind::kStream: return "stream";
    case OdometrySourceKind::kStatic: return "static";
  }
  return "?";
}

bool odometry_source_from_string(const std::string& name, OdometrySourceKind* out) {
  for (OdometrySourceKind k : {OdometrySourceKind::kAuto, OdometrySourceKind::kSimDrift, OdometrySourceKind::kGroundTruth,
                               OdometrySourceKind::kTum, OdometrySourceKind::kStream, OdometrySourceKind::kStatic})
    if (name == to_string(k)) return *out = k, true;
  return false;
}

std::string AppConfig::check() const {
  // Every field within its declared range (the parameter tables), every section whatever the driver: a bad value
  // waiting in an unused section fails on the day the section is used, far from the file that set it. Then the
  // rules between fields.
  if (const std::string r = params::check(app_schema(), *this); !r.empty()) return r;
  if (driver == Driver::kReplay && replay_path.empty()) return "driver replay needs replay_path";
  if (const std::string r = replay.check(); !r.empty()) return "replay." + r;
  for (double f : {v4l2.fx, v4l2.fy})
    if (!(f == 0.0 || f >= 1.0)) return "v4l2.fx and v4l2.fy must be 0 (default) or in [1, 100000]";
  if (!(v4l2.cx <= v4l2.width && v4l2.cy <= v4l2.height))
    return "v4l2.cx and v4l2.cy must be 0 (default) or within the image";
  if (output_dir.empty()) return "output_dir must not be empty";
  if (!segmentation.model_path.empty() && segmentation.label_map_path.empty())
    return "segmentation.label_map_path must be set with a model";
  if (segmentation.backend != "opencv" && segmentation.backend != "cuda")
    return "segmentation.backend: expected opencv or cuda, got '" + segmentation.backend + "'";
  if (segmentation.target != "cpu" && segmentation.target != "cuda" && segmentation.target != "cuda_fp16")
    return "segmentation.target: expected cpu, cuda or cuda_fp16, got '" + segmentation.target + "'";
  if ((segmentation.backend == "cuda") != (segmentation.target != "cpu"))
    return "segmentation.target " + segmentation.target + " does not go with backend " + segmentation.backend +
           " (opencv runs cpu; cuda runs cuda or cuda_fp16)";
  if (gpio.chip.empty()) return "gpio.chip must not be empty (\"sim\" for the simulated chip)";
  if ((gpio.heartbeat_line >= 0 && (gpio.heartbeat_line == gpio.trigger_line || gpio.heartbeat_line == gpio.pause_line)) ||
      (gpio.trigger_line >= 0 && gpio.trigger_line == gpio.pause_line))
    return "gpio: heartbeat_line, trigger_line and pause_line must differ";
  if (const std::string b = building.validate(); !b.empty()) return "building: " + b;
  if (const std::string e = exploration.check(); !e.empty()) return "exploration: " + e;
  if (const std::string c = sim_camera().check(); !c.empty()) return "camera: " + c;
  if (const std::string r = reconstruction.check(); !r.empty()) return "reconstruction: " + r;
  if (const std::string f = frontend.check(); !f.empty()) return "frontend: " + f;
  if (const std::string r = rooms.check(); !r.empty()) return r;
  if (std::string d; !doors.validate(&d)) return d;
  if (const std::string k = keyframes.check(); !k.empty()) return "keyframes: " + k;
  if (const std::string o = check_odometry(); !o.empty()) return "odometry: " + o;
  if (const std::string s = scheduler.check(); !s.empty()) return "scheduler: " + s;
  if (const std::string l = loop_closure.check(); !l.empty()) return "loop_closure: " + l;
  return {};
}

std::string AppConfig::check_odometry() const {
  const Odometry& o = odometry;
  if (o.source == OdometrySourceKind::kSimDrift && driver != Driver::kSim) return "source sim_drift needs driver sim";
  if (o.source == OdometrySourceKind::kGroundTruth && driver == Driver::kV4l2)
    return "source ground_truth needs driver sim or replay (a live camera has no ground truth)";
  if (o.source == OdometrySourceKind::kTum && o.tum_path.empty()) return "source tum needs tum_path";
  if (o.stream_transport != "udp" && o.stream_transport != "unix")
    return "stream_transport must be udp or unix, got '" + o.stream_transport + "'";
  if (o.stream_transport == "unix" && o.stream_unix_path.empty()) return "stream_unix_path must not be empty";
  const double qn = std::sqrt(o.body_q_camera_xyzw[0] * o.body_q_camera_xyzw[0] + o.body_q_camera_xyzw[1] * o.body_q_camera_xyzw[1] +
                              o.body_q_camera_xyzw[2] * o.body_q_camera_xyzw[2] + o.body_q_camera_xyzw[3] * o.body_q_camera_xyzw[3]);
  if (!(std::abs(qn - 1.0) <= 1e-3)) return "body_q_camera_xyzw must be a unit quaternion";
  if (const std::string b = o.buffer.check(); !b.empty()) return b;
  return {};
}

void AppConfig::print(std::FILE* out) const { params::print(app_schema(), *this, out); }

}  // namespace qsg::app
