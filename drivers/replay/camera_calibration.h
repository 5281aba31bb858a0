// The camera calibration file that sits beside replayed frames: Open3D's PinholeCameraIntrinsic JSON (read as-is)
// plus an optional depth scale, so a dataset folder says which camera took it.
#pragma once

#include <string>

#include "core/messages/sensor_types.h"

namespace qsg::replay {

// The name the replay looks for beside the frames, and the name TumWriter writes.
inline constexpr const char* kCalibrationFileName = "calibration.json";

// The file (drivers/replay/README.md has the full description):
//   {
//     "width": 640, "height": 480,
//     "intrinsic_matrix": [fx, 0, 0, 0, fy, 0, cx, cy, 1],   // 3x3, column-major, as Open3D writes it
//     "depth_scale": 5000                                     // optional: raw depth units per metre, or
//     "depth_scale_m": 0.0002                                 // optional: metres per raw unit (not both)
//   }
// "fx", "fy", "cx", "cy" may replace "intrinsic_matrix" (not both). fy may be negative (ICL-NUIM's image y axis
// points up). Open3D's PinholeCameraParameters layout (the camera under "intrinsic") is accepted too; its
// "class_name", "version_*" and "extrinsic" keys, and a "comment" string, are ignored. Any other key is an error,
// so a misspelt depth scale is not silently replaced by a default.
struct CameraCalibration {
  messages::CameraIntrinsics intrinsics;
  float depth_scale_m = 0.0f;  // 0: the file gives no depth scale (the dataset format's default applies)
};

// What is wrong with a camera, or "" when it is plausible: the size within the frame buffers, fx in [1, 1e5],
// |fy| in [1, 1e5] (either sign), the principal point inside the image, all finite.
std::string check_intrinsics(const messages::CameraIntrinsics& intrinsics);
// Depth scales a 16-bit depth image can sensibly carry: 1 um .. 1 m per unit.
inline constexpr double kMinDepthScaleM = 1e-6;
inline constexpr double kMaxDepthScaleM = 1.0;

// Reads and checks a calibration file. Errors start with the path and name the field:
// "<path>: field 'intrinsic_matrix[4]': expected a number".
bool read_camera_calibration(const std::string& path, CameraCalibration* calibration, std::string* error);
// Writes one (Open3D layout, "depth_scale" in units per metre when depth_scale_m is set), replacing the file.
bool write_camera_calibration(const std::string& path, const CameraCalibration& calibration, std::string* error);

}  // namespace qsg::replay
