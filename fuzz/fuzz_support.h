// Shared by the fuzz targets: the readers that take a file name get the input written to a file of this process's
// own (rewritten for every input), under $TMPDIR.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace qsg::fuzz {

inline std::string scratch_path(const char* name) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir != nullptr && *dir != '\0' ? dir : "/tmp") + "/qsg_fuzz_" + std::to_string(::getpid()) + "_" +
         name;
}

// Writes the input to `path`; aborts if it cannot (a broken set-up, not a finding to hide).
inline void write_input(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
}

}  // namespace qsg::fuzz
