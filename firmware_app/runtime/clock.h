// Injected time for the tick loop: the wall clock on the robot, a stepped clock for deterministic tests and
// lockstep simulation (ArduPilot's SITL idea: the test stops and steps time; nothing sleeps).
#pragma once

#include <chrono>
#include <cstdint>
#include <ctime>

namespace qsg::runtime {

class Clock {
 public:
  virtual ~Clock() = default;
  virtual std::int64_t now_ns() const = 0;
  // Waits until t_ns (wall clock) or returns at once (stepped clock: the caller advances time itself).
  virtual void sleep_until_ns(std::int64_t t_ns) = 0;
  virtual bool stepped() const = 0;
};

class WallClock final : public Clock {
 public:
  std::int64_t now_ns() const override {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  void sleep_until_ns(std::int64_t t_ns) override;
  bool stepped() const override { return false; }
};

// The calling thread's CPU time: a cost clock only (Pipeline::set_cost_clock), for measuring what a stage costs
// without the time other processes took the core (a loaded developer machine). Never slept on.
class ThreadCpuClock final : public Clock {
 public:
  std::int64_t now_ns() const override {
    timespec t{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<std::int64_t>(t.tv_sec) * 1000000000 + t.tv_nsec;
  }
  void sleep_until_ns(std::int64_t) override {}
  bool stepped() const override { return false; }
};

class SteppedClock final : public Clock {
 public:
  explicit SteppedClock(std::int64_t start_ns = 0) : now_ns_(start_ns) {}
  std::int64_t now_ns() const override { return now_ns_; }
  void sleep_until_ns(std::int64_t t_ns) override {
    if (t_ns > now_ns_) now_ns_ = t_ns;
  }
  bool stepped() const override { return true; }
  void advance_ns(std::int64_t dt_ns) { now_ns_ += dt_ns > 0 ? dt_ns : 0; }
  void advance_us(std::int64_t dt_us) { advance_ns(dt_us * 1000); }

 private:
  std::int64_t now_ns_;
};

}  // namespace qsg::runtime
