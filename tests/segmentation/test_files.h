// Helpers of the segmentation suite: temporary files and the switch that skips the real-network tests.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include "tests/support/emulation.h"

namespace qsg::segmentation::testing {

// Writes `text` to a file under gtest's temporary directory and returns its path.
inline std::string write_temp_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "qsg_segmentation_" + name;
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
  return path;
}

inline bool env_set(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr && v[0] != '\0' && std::string(v) != "0";
}

// A real forward pass takes ~0.1-0.3 s natively and minutes under qemu (cross builds; support/emulation.h).
inline bool slow_tests_disabled() { return env_set("QSG_SKIP_SLOW_TESTS") || qsg::testing::running_emulated(); }

}  // namespace qsg::segmentation::testing
