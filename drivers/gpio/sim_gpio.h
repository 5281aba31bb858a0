// The simulated GPIO chip: in-memory lines on a stepped clock, inputs that follow a script of (time, level)
// changes, and a record of every edge driven on an output, so the loop's GPIO use is testable without hardware.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/gpio/gpio_line.h"

namespace qsg::gpio {

struct GpioEdge {
  unsigned offset = 0;
  std::int64_t time_ns = 0;
  bool high = false;
};

class SimGpioChip : public GpioChip {
 public:
  struct Config {
    std::string name = "sim-gpiochip0";
    unsigned num_lines = 8;
    std::size_t max_edges = 4096;  // edges recorded; later ones are counted in edges_dropped()
    void print(std::FILE* out) const;
  };

  SimGpioChip();
  explicit SimGpioChip(Config config);
  ~SimGpioChip() override;

  const char* name() const override { return config_.name.c_str(); }
  unsigned num_lines() const override { return config_.num_lines; }
  std::unique_ptr<GpioLine> request(const GpioLineRequest& request, std::string* error) override;

  // Time: inputs read at now_ns() see every scripted change at or before it.
  void set_time_ns(std::int64_t now_ns) { now_ns_ = now_ns; }
  void advance_ns(std::int64_t dt_ns) { now_ns_ += dt_ns; }
  std::int64_t now_ns() const { return now_ns_; }
  // Input script (call in time order per line); set_input_level changes the level now.
  bool script_input(unsigned offset, std::int64_t time_ns, bool high);
  void set_input_level(unsigned offset, bool high);
  // Fault: every call on this line fails (as if the controller were gone) until cleared.
  void set_line_fault(unsigned offset, bool failing);

  // What the outputs did: the level each output was requested with, then every change.
  const std::vector<GpioEdge>& edges() const { return edges_; }
  std::size_t edges_dropped() const { return edges_dropped_; }
  bool level(unsigned offset) const;
  bool is_requested(unsigned offset) const;
  void clear_edges() { edges_.clear(); }

 private:
  friend class SimGpioLine;
  struct Change {
    std::int64_t time_ns = 0;
    bool high = false;
  };
  struct Line {
    bool requested = false;
    bool failing = false;
    GpioDirection direction = GpioDirection::kInput;
    bool level = false;
    std::string consumer;
    std::vector<Change> script;
    std::size_t next_change = 0;
  };
  bool read_level(unsigned offset);
  // Records an edge when the level changes, and the initial level when a line is requested as output.
  void drive(unsigned offset, bool high, bool always_record);
  void release(unsigned offset) { lines_[offset].requested = false; }

  Config config_;
  std::vector<Line> lines_;
  std::vector<GpioEdge> edges_;
  std::size_t edges_dropped_ = 0;
  std::int64_t now_ns_ = 0;
};

}  // namespace qsg::gpio
