// TelemetryWriter: a fixed ring of line slots drained by one writer thread.
#include "firmware_app/runtime/telemetry_writer.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>

namespace qsg::runtime {

TelemetryWriter::~TelemetryWriter() {
  stop();
  if (staging_stream_ != nullptr) std::fclose(staging_stream_);
}

bool TelemetryWriter::init(std::FILE* out, std::uint32_t slots, std::string* error) {
  if (out == nullptr || slots == 0) return *error = "telemetry writer: no output or no slots", false;
  out_ = out;
  slots_ = slots;
  staging_ = std::make_unique<char[]>(kLineBytes);
  lines_ = std::make_unique<char[]>(static_cast<std::size_t>(slots) * kLineBytes);
  length_ = std::make_unique<std::uint32_t[]>(slots);
  staging_stream_ = ::fmemopen(staging_.get(), kLineBytes, "w");
  if (staging_stream_ == nullptr) return *error = "telemetry writer: fmemopen failed", false;
  std::setvbuf(staging_stream_, nullptr, _IONBF, 0);  // straight into the staging buffer: no stdio buffer
  stats_.slots = slots;
  thread_ = std::thread([this] { writer_main(); });
  return true;
}

std::FILE* TelemetryWriter::begin() {
  std::clearerr(staging_stream_);  // a cut line leaves the stream in error: the next line starts clean
  std::fseek(staging_stream_, 0, SEEK_SET);
  return staging_stream_;
}

void TelemetryWriter::commit() {
  std::fflush(staging_stream_);
  const long end = std::ftell(staging_stream_);
  std::size_t n = end > 0 ? static_cast<std::size_t>(end) : 0;
  bool cut = false;
  // fmemopen keeps one byte for its terminating NUL: a line that filled the buffer was cut.
  if (n >= kLineBytes - 1) {
    n = kLineBytes - 1;
    cut = true;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.lines;
    stats_.truncated += cut ? 1 : 0;
    if (count_ == slots_) {
      ++stats_.dropped;
      return;
    }
    const std::uint32_t slot = (head_ + count_) % slots_;
    char* line = &lines_[static_cast<std::size_t>(slot) * kLineBytes];
    std::memcpy(line, staging_.get(), n);
    if (cut) line[n - 1] = '\n';
    length_[slot] = static_cast<std::uint32_t>(n);
    ++count_;
    stats_.in_use = count_;
    stats_.high_water = std::max(stats_.high_water, count_);
    // The writer polls (kPollMs): waking it from here would let it take the loop's core at once (a woken thread
    // preempts its waker on a busy machine). Only a ring half full wakes it early.
    if (2 * count_ < slots_) return;
  }
  wake_.notify_one();
}

void TelemetryWriter::writer_main() {
  // Below the loop (Linux: per-thread nice): when the writer wakes, it should not take the loop's core.
  ::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 10);
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    if (count_ == 0) {
      if (stop_) return;  // stopping, drained
      wake_.wait_for(lock, std::chrono::milliseconds(kPollMs), [&] { return stop_; });
      continue;
    }
    const std::uint32_t slot = head_;
    const char* line = &lines_[static_cast<std::size_t>(slot) * kLineBytes];
    const std::uint32_t n = length_[slot];
    lock.unlock();  // the loop may commit into other slots while this one is written
    const bool ok = std::fwrite(line, 1, n, out_) == n && std::fflush(out_) == 0;
    lock.lock();
    head_ = (head_ + 1) % slots_;
    --count_;
    stats_.in_use = count_;
    ++(ok ? stats_.written : stats_.write_failures);
  }
}

void TelemetryWriter::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

TelemetryWriterStats TelemetryWriter::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace qsg::runtime
