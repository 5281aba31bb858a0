// The calibration file beside replayed frames: Open3D's format read as-is, the depth scale keys, and clear errors
// (naming the file and the field) for malformed, incomplete, absurd and non-finite input.
#include "drivers/replay/camera_calibration.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "tests/drivers/replay/replay_test_util.h"
#include "tests/support/test_data.h"

namespace qsg::replay {
namespace {

using testing::fresh_dir;
using testing::write_file;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

struct Read {
  bool ok = false;
  CameraCalibration calibration;
  std::string error;
};

Read read_text(const std::string& dir, const std::string& text) {
  const std::string path = dir + "/calibration.json";
  write_file(path, text);
  Read r;
  r.ok = read_camera_calibration(path, &r.calibration, &r.error);
  return r;
}

TEST(CameraCalibration, ReadsOpen3dPrimeSenseFileAsIs) {
  CameraCalibration c;
  std::string error;
  ASSERT_TRUE(read_camera_calibration(testing::repo_test_data("rgbd/redwood/camera_primesense.json"), &c, &error))
      << error;
  EXPECT_EQ(c.intrinsics.width, 640);
  EXPECT_EQ(c.intrinsics.height, 480);
  EXPECT_EQ(c.intrinsics.fx, 525.0);
  EXPECT_EQ(c.intrinsics.fy, 525.0);
  EXPECT_EQ(c.intrinsics.cx, 319.5);
  EXPECT_EQ(c.intrinsics.cy, 239.5);
  EXPECT_EQ(c.depth_scale_m, 0.0f) << "no depth scale in Open3D's file: the format's default applies";
}

TEST(CameraCalibration, DepthScaleKeysFieldsNegativeFyAndNestedLayout) {
  const std::string dir = fresh_dir("calibration_good");
  Read r = read_text(dir, R"({"width": 320, "height": 240, "intrinsic_matrix": [262.5, 0, 0, 0, 263, 0, 159.5, 119.25, 1],
                              "depth_scale": 5000})");
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.calibration.intrinsics.fy, 263.0);
  EXPECT_EQ(r.calibration.intrinsics.cy, 119.25);
  EXPECT_EQ(r.calibration.depth_scale_m, 1.0f / 5000.0f);
  r = read_text(dir, R"({"width": 640, "height": 480, "fx": 481.2, "fy": -480, "cx": 319.5, "cy": 239.5,
                         "depth_scale_m": 0.001, "comment": "ICL-NUIM's negative fy"})");
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.calibration.intrinsics.fx, 481.2);
  EXPECT_EQ(r.calibration.intrinsics.fy, -480.0);
  EXPECT_EQ(r.calibration.depth_scale_m, 0.001f);
  // Open3D's PinholeCameraParameters: the camera under "intrinsic", with keys that are not ours.
  r = read_text(dir, R"({"class_name": "PinholeCameraParameters", "version_major": 1, "version_minor": 0,
                         "extrinsic": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1],
                         "intrinsic": {"width": 640, "height": 480,
                                       "intrinsic_matrix": [415.69, 0, 0, 0, 415.69, 0, 319.5, 239.5, 1]},
                         "depth_scale": 1000})");
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.calibration.intrinsics.fx, 415.69);
  EXPECT_EQ(r.calibration.depth_scale_m, 0.001f);
}

TEST(CameraCalibration, MalformedAndNonFiniteInputNamesTheFile) {
  const std::string dir = fresh_dir("calibration_malformed");
  const std::string path = dir + "/calibration.json";
  for (const char* text : {"{\"width\": 640,", "", "[1, 2, 3]", "\"camera\"",
                           R"({"width": 640, "height": 480, "intrinsic_matrix": [NaN, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})",
                           R"({"width": 640, "height": 480, "intrinsic_matrix": [Infinity, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})"}) {
    const Read r = read_text(dir, text);
    EXPECT_FALSE(r.ok) << text;
    EXPECT_TRUE(contains(r.error, path + ": ")) << text << " -> " << r.error;
  }
  // A number too large for a double is not finite either.
  Read r = read_text(dir, R"({"width": 640, "height": 480, "intrinsic_matrix": [1e999, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})");
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(contains(r.error, path + ": ")) << r.error;
  CameraCalibration c;
  std::string error;
  EXPECT_FALSE(read_camera_calibration(dir + "/absent.json", &c, &error));
  EXPECT_EQ(error, dir + "/absent.json: cannot open");
}

TEST(CameraCalibration, MissingKeysAreNamed) {
  const std::string dir = fresh_dir("calibration_missing");
  const struct {
    const char* text;
    const char* expected;
  } cases[] = {
      {R"({"height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})", "field 'width': expected an integer"},
      {R"({"width": 640, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})", "field 'height': expected an integer"},
      {R"({"width": 640, "height": 480})", "field 'intrinsic_matrix': expected an array of 9 numbers"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5]})",
       "field 'intrinsic_matrix': expected an array of 9 numbers"},
      {R"({"width": 640, "height": 480, "fx": 525, "fy": 525, "cx": 319.5})", "field 'cy': missing"},
      {R"({"width": 640.5, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})",
       "field 'width': expected an integer"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, "525", 0, 319.5, 239.5, 1]})",
       "field 'intrinsic_matrix[4]': expected a number"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1],
           "depth_scale": "5000"})",
       "field 'depth_scale': expected a number"},
  };
  for (const auto& c : cases) {
    const Read r = read_text(dir, c.text);
    EXPECT_FALSE(r.ok) << c.text;
    EXPECT_TRUE(contains(r.error, dir + "/calibration.json: " + c.expected)) << c.text << " -> " << r.error;
  }
}

TEST(CameraCalibration, AbsurdValuesAndMistakesAreRefused) {
  const std::string dir = fresh_dir("calibration_absurd");
  const std::string k = R"("intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1])";
  const struct {
    std::string text;
    const char* expected;
  } cases[] = {
      {R"({"width": 0, "height": 480, )" + k + "}", "image size 0x480 must be positive"},
      {R"({"width": 1280, "height": 720, )" + k + "}", "image size 1280x720 is larger than the frame buffers (640x480)"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [0, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})", "fx 0 is outside"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [-525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})", "fx -525 is outside"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [1e9, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})", "fx 1000000000 is outside"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 0.5, 0, 319.5, 239.5, 1]})", "fy 0.5 is outside"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 3195, 239.5, 1]})",
       "cx 3195 is outside the 640x480 image"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, -1, 1]})",
       "cy -1 is outside the 640x480 image"},
      // Row-major (cx, cy in the last column) and skew are mistakes, not cameras.
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]})",
       "where a row-major matrix keeps them"},
      {R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 2, 525, 0, 319.5, 239.5, 1]})", "no skew"},
      {R"({"width": 640, "height": 480, )" + k + R"(, "depth_scale": 0})", "field 'depth_scale': 0 units per metre"},
      {R"({"width": 640, "height": 480, )" + k + R"(, "depth_scale": -5000})", "field 'depth_scale': -5000"},
      {R"({"width": 640, "height": 480, )" + k + R"(, "depth_scale_m": 5})", "field 'depth_scale_m': 5 metres per unit"},
      {R"({"width": 640, "height": 480, )" + k + R"(, "depth_scale": 5000, "depth_scale_m": 0.0002})",
       "either 'depth_scale' or 'depth_scale_m', not both"},
      {R"({"width": 640, "height": 480, )" + k + R"(, "fx": 525})", "either 'intrinsic_matrix' or 'fx'"},
      {R"({"width": 640, "height": 480, )" + k + R"(, "depth_scal": 5000})", "unknown field 'depth_scal'"},
  };
  for (const auto& c : cases) {
    const Read r = read_text(dir, c.text);
    EXPECT_FALSE(r.ok) << c.text;
    EXPECT_TRUE(contains(r.error, dir + "/calibration.json: ")) << r.error;
    EXPECT_TRUE(contains(r.error, c.expected)) << c.text << " -> " << r.error;
  }
}

TEST(CameraCalibration, WrittenFileReadsBackExactly) {
  const std::string dir = fresh_dir("calibration_write");
  for (const float scale : {1.0f / 5000.0f, 0.001f, 0.00025f, 1.0f / 3000.0f, 0.0001234f}) {
    CameraCalibration c;
    c.intrinsics = {320, 240, 262.5, 262.5, 159.5, 119.5};
    c.intrinsics.fy = -0.1 + 262.6;  // not a short decimal: the text must still round-trip
    c.depth_scale_m = scale;
    std::string error;
    ASSERT_TRUE(write_camera_calibration(dir + "/calibration.json", c, &error)) << error;
    CameraCalibration back;
    ASSERT_TRUE(read_camera_calibration(dir + "/calibration.json", &back, &error)) << error;
    EXPECT_EQ(back.intrinsics.width, 320);
    EXPECT_EQ(back.intrinsics.height, 240);
    EXPECT_EQ(back.intrinsics.fx, c.intrinsics.fx);
    EXPECT_EQ(back.intrinsics.fy, c.intrinsics.fy);
    EXPECT_EQ(back.intrinsics.cx, c.intrinsics.cx);
    EXPECT_EQ(back.intrinsics.cy, c.intrinsics.cy);
    EXPECT_EQ(back.depth_scale_m, scale);
  }
  // TUM's scale is written the way Open3D spells it.
  CameraCalibration c;
  c.intrinsics = {320, 240, 262.5, 262.5, 159.5, 119.5};
  c.depth_scale_m = 1.0f / 5000.0f;
  std::string error;
  ASSERT_TRUE(write_camera_calibration(dir + "/tum.json", c, &error)) << error;
  std::ifstream in(dir + "/tum.json");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_TRUE(contains(text.str(), "\"depth_scale\": 5000")) << text.str();
  EXPECT_TRUE(contains(text.str(), "\"intrinsic_matrix\": [262.5, 0, 0, 0, 262.5, 0, 159.5, 119.5, 1]")) << text.str();
  // A camera that could not be read back is not written.
  c.intrinsics.fx = 0.0;
  EXPECT_FALSE(write_camera_calibration(dir + "/bad.json", c, &error));
  EXPECT_TRUE(contains(error, "fx 0 is outside")) << error;
}

}  // namespace
}  // namespace qsg::replay
