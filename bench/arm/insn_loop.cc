// A tiny arm64 program for the instruction-counting check (insn_count_check.cmake): a loop of N iterations of
// two instructions, bracketed by the app's own stage markers, inside an outer marked stage.
//   insn_loop N [--markers]     markers stay off, as in the app, unless --markers switches them on
#include <cstdlib>
#include <cstring>

#include "firmware_app/runtime/stage_marker.h"

int main(int argc, char** argv) {
  unsigned long n = argc > 1 ? std::strtoul(argv[1], nullptr, 10) : 0;
  if (argc > 2 && std::strcmp(argv[2], "--markers") == 0) qsg::runtime::set_stage_markers(true);
  const std::uint64_t iterations = n;
  qsg::runtime::stage_begin(3, 1);
  qsg::runtime::stage_begin(5, iterations);
#if defined(__aarch64__)
  if (n > 0) __asm__ volatile("1: subs %0, %0, #1\n\tb.ne 1b" : "+r"(n));
#else
  while (n > 0) __asm__ volatile("" : "+r"(n)), --n;
#endif
  qsg::runtime::stage_end(5, iterations);
  qsg::runtime::stage_end(3, 1);
  return 0;
}
