// Reading, checking and writing camera calibration files.
#include "drivers/replay/camera_calibration.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>

namespace qsg::replay {
namespace {

using Json = nlohmann::json;

// Shortest text that reads back as the same double (15 digits usually do; 17 always do).
std::string number_text(double v) {
  char text[40];
  std::snprintf(text, sizeof(text), "%.15g", v);
  if (std::strtod(text, nullptr) != v) std::snprintf(text, sizeof(text), "%.17g", v);
  return text;
}

constexpr const char* kKnownKeys[] = {"width",         "height",  "intrinsic_matrix", "fx",
                                      "fy",            "cx",      "cy",               "depth_scale",
                                      "depth_scale_m", "comment", "class_name",       "version_major",
                                      "version_minor", "extrinsic", "intrinsic"};

bool known_key(const std::string& key) {
  for (const char* k : kKnownKeys)
    if (key == k) return true;
  return false;
}

}  // namespace

std::string check_intrinsics(const messages::CameraIntrinsics& k) {
  const std::string size = std::to_string(k.width) + "x" + std::to_string(k.height);
  if (k.width <= 0 || k.height <= 0) return "image size " + size + " must be positive";
  if (k.width > messages::kMaxFrameWidth || k.height > messages::kMaxFrameHeight) {
    return "image size " + size + " is larger than the frame buffers (" + std::to_string(messages::kMaxFrameWidth) +
           "x" + std::to_string(messages::kMaxFrameHeight) + ")";
  }
  // Written so that NaN fails every test.
  if (!(k.fx >= 1.0 && k.fx <= 1e5)) return "fx " + number_text(k.fx) + " is outside [1, 1e5] pixels";
  if (!(std::abs(k.fy) >= 1.0 && std::abs(k.fy) <= 1e5))
    return "fy " + number_text(k.fy) + " is outside [1, 1e5] pixels (either sign)";
  if (!(k.cx >= 0.0 && k.cx <= k.width))
    return "cx " + number_text(k.cx) + " is outside the " + size + " image (0 .. " + std::to_string(k.width) + ")";
  if (!(k.cy >= 0.0 && k.cy <= k.height))
    return "cy " + number_text(k.cy) + " is outside the " + size + " image (0 .. " + std::to_string(k.height) + ")";
  return {};
}

bool read_camera_calibration(const std::string& path, CameraCalibration* calibration, std::string* error) {
  const auto fail = [&](const std::string& message) {
    if (error) *error = path + ": " + message;
    return false;
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail("cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  Json doc;
  try {
    doc = Json::parse(text.str());
  } catch (const Json::exception& e) {
    return fail(e.what());  // names the byte; NaN and Infinity are not JSON and end up here
  }
  if (!doc.is_object()) return fail("expected a JSON object");
  const Json* cam = &doc;
  if (!doc.contains("intrinsic_matrix") && !doc.contains("fx") && doc.contains("intrinsic")) {
    if (!doc["intrinsic"].is_object()) return fail("field 'intrinsic': expected an object");
    cam = &doc["intrinsic"];
  }
  const Json* const levels[] = {&doc, cam};
  for (const Json* level : levels) {
    for (auto it = level->begin(); it != level->end(); ++it) {
      if (!known_key(it.key())) {
        return fail("unknown field '" + it.key() +
                    "' (expected width, height, intrinsic_matrix or fx, fy, cx, cy, and depth_scale or depth_scale_m)");
      }
    }
  }
  const auto integer_field = [&](const char* key, int* value) {
    if (!cam->contains(key) || !(*cam)[key].is_number_integer())
      return fail(std::string("field '") + key + "': expected an integer");
    const std::int64_t v = (*cam)[key].get<std::int64_t>();
    if (v < -100000 || v > 100000) return fail(std::string("field '") + key + "': " + std::to_string(v) + " is absurd");
    *value = static_cast<int>(v);
    return true;
  };
  const auto number_field = [&](const Json& holder, const std::string& key, double* value) {
    const Json& v = holder[key];
    if (!v.is_number()) return fail("field '" + key + "': expected a number");
    *value = v.get<double>();
    if (!std::isfinite(*value)) return fail("field '" + key + "': not a finite number");
    return true;
  };

  CameraCalibration c;
  messages::CameraIntrinsics& k = c.intrinsics;
  if (!integer_field("width", &k.width) || !integer_field("height", &k.height)) return false;
  const bool has_matrix = cam->contains("intrinsic_matrix");
  const bool has_fields = cam->contains("fx") || cam->contains("fy") || cam->contains("cx") || cam->contains("cy");
  if (has_matrix && has_fields) return fail("give either 'intrinsic_matrix' or 'fx', 'fy', 'cx', 'cy', not both");
  if (has_fields) {
    const std::pair<const char*, double*> fields[] = {{"fx", &k.fx}, {"fy", &k.fy}, {"cx", &k.cx}, {"cy", &k.cy}};
    for (const auto& [key, value] : fields) {
      if (!cam->contains(key)) return fail(std::string("field '") + key + "': missing (fx, fy, cx and cy go together)");
      if (!number_field(*cam, key, value)) return false;
    }
  } else {
    const Json& matrix = has_matrix ? (*cam)["intrinsic_matrix"] : Json();
    if (!matrix.is_array() || matrix.size() != 9)
      return fail("field 'intrinsic_matrix': expected an array of 9 numbers (column-major 3x3)");
    double m[9];
    for (std::size_t i = 0; i < 9; ++i) {
      const Json& v = matrix[i];
      if (!v.is_number())
        return fail("field 'intrinsic_matrix[" + std::to_string(i) + "]': expected a number");
      m[i] = v.get<double>();
      if (!std::isfinite(m[i]))
        return fail("field 'intrinsic_matrix[" + std::to_string(i) + "]': not a finite number");
    }
    // Column-major: m[0] = K(0,0), m[4] = K(1,1), m[6] = K(0,2), m[7] = K(1,2); the rest is 0 but K(2,2) = 1.
    if (m[1] != 0.0 || m[2] != 0.0 || m[3] != 0.0 || m[5] != 0.0 || m[8] != 1.0) {
      if ((m[2] != 0.0 || m[5] != 0.0) && m[6] == 0.0 && m[7] == 0.0)
        return fail("field 'intrinsic_matrix': cx and cy are where a row-major matrix keeps them; Open3D's is "
                    "column-major: [fx, 0, 0, 0, fy, 0, cx, cy, 1]");
      return fail("field 'intrinsic_matrix': expected [fx, 0, 0, 0, fy, 0, cx, cy, 1] (column-major, no skew)");
    }
    k.fx = m[0];
    k.fy = m[4];
    k.cx = m[6];
    k.cy = m[7];
  }
  if (const std::string bad = check_intrinsics(k); !bad.empty()) return fail(bad);

  // The depth scale, on the top level or beside the camera.
  const Json* holder = nullptr;
  std::string key;
  for (const char* name : {"depth_scale", "depth_scale_m"}) {
    for (const Json* level : levels) {
      if (!level->contains(name)) continue;
      if (holder != nullptr && key != name) return fail("give either 'depth_scale' or 'depth_scale_m', not both");
      holder = level;
      key = name;
    }
  }
  if (holder != nullptr) {
    double value = 0.0;
    if (!number_field(*holder, key, &value)) return false;
    if (key == "depth_scale") {
      if (!(value >= 1.0 / kMaxDepthScaleM && value <= 1.0 / kMinDepthScaleM))
        return fail("field 'depth_scale': " + number_text(value) +
                    " units per metre is outside [1, 1e6] (5000 for TUM, 1000 for millimetres)");
      c.depth_scale_m = static_cast<float>(1.0 / value);
    } else {
      if (!(value >= kMinDepthScaleM && value <= kMaxDepthScaleM))
        return fail("field 'depth_scale_m': " + number_text(value) +
                    " metres per unit is outside [1e-6, 1] (0.0002 for TUM, 0.001 for millimetres)");
      c.depth_scale_m = static_cast<float>(value);
    }
  }
  *calibration = c;
  return true;
}

bool write_camera_calibration(const std::string& path, const CameraCalibration& calibration, std::string* error) {
  const messages::CameraIntrinsics& k = calibration.intrinsics;
  if (const std::string bad = check_intrinsics(k); !bad.empty()) {
    if (error) *error = path + ": not written: " + bad;
    return false;
  }
  std::string depth;
  if (calibration.depth_scale_m > 0.0f) {
    // Units per metre when that is a whole number (5000, 1000), as Open3D spells it; else metres per unit.
    const double per_m = 1.0 / static_cast<double>(calibration.depth_scale_m);
    const double whole = std::round(per_m);
    if (std::abs(per_m - whole) < 1e-6 * per_m && static_cast<float>(1.0 / whole) == calibration.depth_scale_m)
      depth = ",\n  \"depth_scale\": " + number_text(whole);
    else
      depth = ",\n  \"depth_scale_m\": " + number_text(static_cast<double>(calibration.depth_scale_m));
  }
  const std::string text =
      "{\n  \"comment\": \"camera of the frames in this folder (quadsg drivers/replay/README.md)\",\n"
      "  \"width\": " + std::to_string(k.width) + ",\n  \"height\": " + std::to_string(k.height) +
      ",\n  \"intrinsic_matrix\": [" + number_text(k.fx) + ", 0, 0, 0, " + number_text(k.fy) + ", 0, " +
      number_text(k.cx) + ", " + number_text(k.cy) + ", 1]" + depth + "\n}\n";
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    if (error) *error = path + ": cannot create";
    return false;
  }
  const bool written = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !written) {
    if (error) *error = path + ": write failed";
    return false;
  }
  return true;
}

}  // namespace qsg::replay
