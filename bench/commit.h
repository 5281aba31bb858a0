// The commit a benchmark or evaluation binary was built from, stamped at build time (bench/commit_stamp.cmake):
// the short hash, with "-dirty" when tracked files had uncommitted changes, or "unknown" outside a git checkout.
#pragma once

namespace qsg::bench {

const char* git_commit();

}  // namespace qsg::bench
