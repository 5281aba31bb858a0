// The GPIO device class: a chip hands out lines by offset, a line is driven (output) or read (input). Backends:
// libgpiod (gpiod_chip.h) on the robot and an in-memory chip with scripted inputs (sim_gpio.h) on a desk.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

namespace qsg::gpio {

enum class GpioDirection : std::uint8_t { kInput, kOutput };
const char* to_string(GpioDirection direction);

struct GpioLineRequest {
  unsigned offset = 0;
  GpioDirection direction = GpioDirection::kInput;
  bool initial_high = false;         // outputs: level driven from the moment of the request
  std::string consumer = "quadsg";   // shown by gpioinfo next to the line
};

struct GpioCounters {
  std::uint64_t writes = 0;
  std::uint64_t reads = 0;
  std::uint64_t errors = 0;  // calls that failed (see last_error())
};

// One requested line; released when destroyed. Must not outlive its chip. set() and get() never allocate.
class GpioLine {
 public:
  virtual ~GpioLine() = default;
  virtual const char* name() const = 0;  // "<chip>:<offset>"
  virtual GpioDirection direction() const = 0;
  // Outputs only: drives the line. false (counted, last_error()) on an input or a device error.
  virtual bool set(bool high) = 0;
  // Inputs: the level on the pin; outputs: the level the chip reports driving.
  virtual bool get(bool* high) = 0;
  virtual const char* last_error() const = 0;
  virtual const GpioCounters& counters() const = 0;
};

// What every backend's line keeps: its name, direction, counters and the text of its last error (fixed
// buffers: set() and get() never allocate). Backends derive from it and implement set() and get().
class GpioLineBase : public GpioLine {
 public:
  const char* name() const override { return name_; }
  GpioDirection direction() const override { return direction_; }
  const char* last_error() const override { return error_; }
  const GpioCounters& counters() const override { return counters_; }

 protected:
  GpioLineBase(const char* chip_name, unsigned offset, GpioDirection direction);
  // Records the error (printf-style), counts it, returns false.
  bool fail(const char* format, ...) __attribute__((format(printf, 2, 3)));
  bool is_output() const { return direction_ == GpioDirection::kOutput; }

  char name_[96] = {};
  GpioCounters counters_;

 private:
  GpioDirection direction_;
  char error_[192] = {};
};

class GpioChip {
 public:
  virtual ~GpioChip() = default;
  virtual const char* name() const = 0;
  virtual unsigned num_lines() const = 0;
  // nullptr with *error naming the chip and offset when the offset is out of range, the line is busy (requested
  // by this or another process) or the request fails.
  virtual std::unique_ptr<GpioLine> request(const GpioLineRequest& request, std::string* error) = 0;
};

}  // namespace qsg::gpio
