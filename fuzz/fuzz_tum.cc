// TUM readers (drivers/replay): a TUM RGB-D frame list (rgb.txt / depth.txt) and a TUM trajectory, strict and
// skipping malformed lines: any file is read or refused with an error; what was read is finite and in order.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "drivers/replay/trajectory.h"
#include "drivers/replay/tum_replay.h"
#include "fuzz/fuzz_support.h"

using namespace qsg;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string folder = [] {
    const std::string dir = fuzz::scratch_path("tum");
    std::system(("mkdir -p '" + dir + "'").c_str());
    return dir;
  }();
  fuzz::write_input(folder + "/depth.txt", data, size);
  std::vector<replay::ListedFile> files;
  std::string error;
  if (replay::read_tum_list(folder, "depth.txt", &files, &error)) {
    for (const replay::ListedFile& f : files)
      if (f.path.empty()) std::abort();
  } else if (error.empty()) {
    std::abort();
  }
  replay::Trajectory strict, skipping;
  replay::TumSkipped skipped;
  const bool strict_ok = replay::read_tum_trajectory(folder + "/depth.txt", &strict, &error);
  if (replay::read_tum_trajectory_skipping(folder + "/depth.txt", &skipping, &skipped, &error)) {
    // A file the strict reader takes, the skipping reader takes whole.
    if (strict_ok && (skipped.lines != 0 || skipping.size() != strict.size())) std::abort();
  }
  return 0;
}
