// Test-data lookup shared by every suite.
#include "tests/support/test_data.h"

#include <sys/stat.h>

#include <cstdlib>

namespace qsg::testing {
namespace {
bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}
}  // namespace

std::string shared_data_dir() {
  if (const char* env = std::getenv("QSG_SHARED_DATA"); env != nullptr && exists(env)) return env;
  const std::string beside = std::string(QSG_SOURCE_DIR) + "/../shared/data";
  return exists(beside) ? beside : std::string();
}

std::string shared_data_file(const std::string& relative) {
  const std::string dir = shared_data_dir();
  if (dir.empty()) return {};
  const std::string path = dir + "/" + relative;
  return exists(path) ? path : std::string();
}

std::string repo_test_data(const std::string& relative) { return std::string(QSG_SOURCE_DIR) + "/tests/data/" + relative; }

}  // namespace qsg::testing
