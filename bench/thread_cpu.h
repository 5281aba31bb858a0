// This thread's CPU time in seconds: what a single-threaded run costs, whatever else shares the machine.
#pragma once

#include <time.h>

namespace qsg::bench {

inline double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace qsg::bench
