// Locates test inputs: the repository's own tests/data and the shared real-data folder beside the repository.
#pragma once

#include <string>

namespace qsg::testing {

// Path of ../shared/data (or $QSG_SHARED_DATA); empty when it is absent.
std::string shared_data_dir();
// Path of a file under the shared data folder, or empty when the folder or the file is absent.
std::string shared_data_file(const std::string& relative);
// Path under the repository's tests/data.
std::string repo_test_data(const std::string& relative);

}  // namespace qsg::testing

// Skips the current test with a clear message when a shared-data file is missing.
#define QSG_REQUIRE_SHARED_DATA(var, relative)                                                           \
  const std::string var = ::qsg::testing::shared_data_file(relative);                                   \
  if (var.empty()) GTEST_SKIP() << "shared data file '" << (relative) << "' not found (looked in "       \
                                << "$QSG_SHARED_DATA and ../shared/data beside the repository); skipping"
