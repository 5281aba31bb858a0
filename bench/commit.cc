#include "bench/commit.h"

#include "qsg_commit.h"  // generated into the build tree at every build

namespace qsg::bench {

const char* git_commit() { return QSG_GIT_COMMIT; }

}  // namespace qsg::bench
