// Shared main() of the micro-benchmarks: tags every run (console and --benchmark_out JSON) with the commit,
// the board table and the build type, so figures compare across commits and machines.
#include <benchmark/benchmark.h>

#include <cstdio>

#include "bench/commit.h"

int main(int argc, char** argv) {
#ifdef QSG_HAVE_BENCHMARK_CONTEXT
  benchmark::AddCustomContext("commit", qsg::bench::git_commit());
  benchmark::AddCustomContext("board", QSG_BOARD_NAME);
  benchmark::AddCustomContext("build_type", QSG_BUILD_TYPE);
#else
  std::fprintf(stderr, "commit %s, board %s, build %s\n", qsg::bench::git_commit(), QSG_BOARD_NAME, QSG_BUILD_TYPE);
#endif
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
#ifdef QSG_HAVE_BENCHMARK_CONTEXT
  benchmark::Shutdown();
#endif
  return 0;
}
