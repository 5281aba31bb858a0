// Telemetry without blocking the loop: the loop prints a line into a fixed staging buffer (a FILE* opened once on
// it with fmemopen), commit() copies it into one of a fixed number of line slots, and a writer thread (nice +10,
// polling every kPollMs so that the loop never wakes it) drains the slots to the output (a pipe, a terminal, a
// file) and flushes. When every slot is full (the output is slower than
// the lines: a stalled pipe) the new line is dropped and counted; a line longer than the staging buffer is cut and
// counted. After init() nothing allocates. Reports capacity, use, high-water mark and failures like every queue.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace qsg::runtime {

struct TelemetryWriterStats {
  std::uint32_t slots = 0;
  std::uint32_t in_use = 0;
  std::uint32_t high_water = 0;
  std::uint64_t lines = 0;           // committed
  std::uint64_t written = 0;         // written to the output
  std::uint64_t dropped = 0;         // every slot was full
  std::uint64_t truncated = 0;       // longer than the line buffer: cut
  std::uint64_t write_failures = 0;  // the output refused a line (EPIPE, disk full): counted, the run goes on
};

class TelemetryWriter {
 public:
  static constexpr std::size_t kLineBytes = 16384;  // the stores line (telemetry_stores) names every store
  static constexpr int kPollMs = 100;  // the writer looks for lines this often (commit() does not wake it)

  TelemetryWriter() = default;
  ~TelemetryWriter();
  TelemetryWriter(const TelemetryWriter&) = delete;
  TelemetryWriter& operator=(const TelemetryWriter&) = delete;

  // `out` must outlive the writer. slots >= 1.
  bool init(std::FILE* out, std::uint32_t slots, std::string* error);
  bool initialized() const { return staging_stream_ != nullptr; }
  // The loop: a stream positioned at the start of the staging buffer; print one line into it, then commit().
  std::FILE* begin();
  void commit();
  // Drains what is queued, then joins the writer (also at destruction).
  void stop();
  TelemetryWriterStats stats() const;

 private:
  void writer_main();

  std::FILE* out_ = nullptr;
  std::unique_ptr<char[]> staging_;
  std::FILE* staging_stream_ = nullptr;
  std::unique_ptr<char[]> lines_;            // slots x kLineBytes
  std::unique_ptr<std::uint32_t[]> length_;  // bytes of each slot's line
  std::uint32_t slots_ = 0;
  std::uint32_t head_ = 0;  // oldest queued line
  std::uint32_t count_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  TelemetryWriterStats stats_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace qsg::runtime
