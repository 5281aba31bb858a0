// Heartbeat, trigger pulse and debounced pause switch; see gpio_devices.h.
#include "drivers/gpio/gpio_devices.h"

namespace qsg::gpio {

bool Heartbeat::toggle() {
  if (!line_.set(!level_)) {
    ++failures_;
    return false;
  }
  level_ = !level_;
  ++toggles_;
  return true;
}

void TriggerPulse::Config::print(std::FILE* out) const {
  std::fprintf(out, "TriggerPulse::Config: width_ns=%lld\n", static_cast<long long>(width_ns));
}

bool TriggerPulse::fire(std::int64_t now_ns) {
  if (active_) {
    ++overlapping_;
    return false;
  }
  if (!line_.set(true)) {
    ++failures_;
    return false;
  }
  active_ = true;
  started_ns_ = now_ns;
  ++pulses_;
  return true;
}

bool TriggerPulse::update(std::int64_t now_ns) {
  if (!active_ || now_ns - started_ns_ < config_.width_ns) return true;
  if (!line_.set(false)) {
    ++failures_;
    return false;  // still active: the next update tries again
  }
  active_ = false;
  return true;
}

void PauseSwitch::Config::print(std::FILE* out) const {
  std::fprintf(out, "PauseSwitch::Config: debounce_ns=%lld active_high=%d\n", static_cast<long long>(debounce_ns),
               active_high ? 1 : 0);
}

bool PauseSwitch::update(std::int64_t now_ns) {
  bool raw = false;
  if (!line_.get(&raw)) {
    ++failures_;
    return false;
  }
  if (!initialised_) {
    // The level at start-up is taken as is: there is no earlier state to protect.
    initialised_ = true;
    stable_ = candidate_ = raw;
    candidate_since_ns_ = now_ns;
    return true;
  }
  if (raw != candidate_) {
    if (candidate_ != stable_) ++bounces_;  // the previous change did not last
    candidate_ = raw;
    candidate_since_ns_ = now_ns;
  }
  if (candidate_ != stable_ && now_ns - candidate_since_ns_ >= config_.debounce_ns) {
    stable_ = candidate_;
    ++changes_;
  }
  return true;
}

}  // namespace qsg::gpio
