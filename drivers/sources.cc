// Names of driver read results.
#include "drivers/sources.h"

namespace qsg::drivers {

const char* to_string(ReadStatus status) {
  switch (status) {
    case ReadStatus::kOk: return "ok";
    case ReadStatus::kTimeout: return "timeout";
    case ReadStatus::kEndOfStream: return "end of stream";
    case ReadStatus::kDisconnected: return "disconnected";
    case ReadStatus::kBadFrame: return "bad frame";
  }
  return "?";
}

}  // namespace qsg::drivers
