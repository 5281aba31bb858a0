// What the firmware does with GPIO, on top of any GpioLine backend: a heartbeat output the loop toggles, a camera
// trigger output pulsed for a fixed width, and a pause-switch input read with a debounce. Time is passed in, so
// the same code runs on the loop's clock and on a test's stepped one; nothing sleeps or allocates.
#pragma once

#include <cstdint>
#include <cstdio>

#include "drivers/gpio/gpio_line.h"

namespace qsg::gpio {

// Toggled once per loop tick: a scope or an LED on the line shows the loop is alive and at what rate.
class Heartbeat {
 public:
  explicit Heartbeat(GpioLine& line, bool initial_high = false) : line_(line), level_(initial_high) {}
  bool toggle();  // false (counted) if the line refused
  bool level() const { return level_; }
  std::uint64_t toggles() const { return toggles_; }
  std::uint64_t failures() const { return failures_; }

 private:
  GpioLine& line_;
  bool level_;
  std::uint64_t toggles_ = 0;
  std::uint64_t failures_ = 0;
};

// A camera trigger: fire() raises the line, update() lowers it once width_ns has passed.
class TriggerPulse {
 public:
  struct Config {
    std::int64_t width_ns = 1'000'000;  // the camera latches on the rising edge; 1 ms is well above its minimum
    void print(std::FILE* out) const;
  };
  TriggerPulse(GpioLine& line, const Config& config) : line_(line), config_(config) {}
  // Starts a pulse at now_ns. A fire() while a pulse is still high is refused and counted (overlapping).
  bool fire(std::int64_t now_ns);
  // Call every tick: ends the pulse once its width has passed. false if the line refused.
  bool update(std::int64_t now_ns);
  bool active() const { return active_; }
  std::uint64_t pulses() const { return pulses_; }
  std::uint64_t overlapping() const { return overlapping_; }
  std::uint64_t failures() const { return failures_; }

 private:
  GpioLine& line_;
  Config config_;
  bool active_ = false;
  std::int64_t started_ns_ = 0;
  std::uint64_t pulses_ = 0;
  std::uint64_t overlapping_ = 0;
  std::uint64_t failures_ = 0;
};

// A pause switch: the state changes only after the raw level stayed different for debounce_ns.
class PauseSwitch {
 public:
  struct Config {
    std::int64_t debounce_ns = 20'000'000;  // mechanical switches bounce for a few ms
    bool active_high = true;                // the level that means "paused"
    void print(std::FILE* out) const;
  };
  PauseSwitch(GpioLine& line, const Config& config) : line_(line), config_(config) {}
  // Samples the line at now_ns (call every tick). false (counted) if the read failed; the state is kept.
  bool update(std::int64_t now_ns);
  bool paused() const { return stable_ == config_.active_high; }
  std::uint64_t changes() const { return changes_; }
  std::uint64_t bounces() const { return bounces_; }  // level changes that did not last debounce_ns
  std::uint64_t failures() const { return failures_; }

 private:
  GpioLine& line_;
  Config config_;
  bool initialised_ = false;
  bool stable_ = false;
  bool candidate_ = false;
  std::int64_t candidate_since_ns_ = 0;
  std::uint64_t changes_ = 0;
  std::uint64_t bounces_ = 0;
  std::uint64_t failures_ = 0;
};

}  // namespace qsg::gpio
