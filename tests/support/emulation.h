// Whether this test binary runs under qemu-user, as a cross build's ctest does.
//
// Under qemu-user a test cannot start another arm64 program (without binfmt_misc the host kernel refuses to
// execute it), and a real network's forward pass takes minutes. Cross builds compile QSG_TESTS_EMULATED in
// (tests/CMakeLists.txt); the environment variable QSG_EMULATED overrides either way, e.g. QSG_EMULATED=0 when
// a cross-built test binary is copied to the board and run natively.
#pragma once

#include <cstdlib>
#include <string>

namespace qsg::testing {

inline bool running_emulated() {
  if (const char* v = std::getenv("QSG_EMULATED"); v != nullptr && v[0] != '\0') return std::string(v) != "0";
#ifdef QSG_TESTS_EMULATED
  return true;
#else
  return false;
#endif
}

// Whether AddressSanitizer is compiled in: it replaces mlock/mlockall with no-ops that report success.
inline constexpr bool address_sanitizer() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

}  // namespace qsg::testing
