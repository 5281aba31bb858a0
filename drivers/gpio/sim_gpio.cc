// The simulated GPIO chip; see sim_gpio.h.
#include "drivers/gpio/sim_gpio.h"

#include <cstdarg>

namespace qsg::gpio {

class SimGpioLine : public GpioLineBase {
 public:
  SimGpioLine(SimGpioChip& chip, unsigned offset, GpioDirection direction)
      : GpioLineBase(chip.name(), offset, direction), chip_(chip), offset_(offset) {}
  ~SimGpioLine() override { chip_.release(offset_); }

  bool set(bool high) override {
    if (!is_output()) return fail("%s: set() on a line requested as input", name_);
    if (chip_.lines_[offset_].failing) return fail("%s: set failed: simulated line fault", name_);
    chip_.drive(offset_, high, false);
    ++counters_.writes;
    return true;
  }

  bool get(bool* high) override {
    if (chip_.lines_[offset_].failing) return fail("%s: get failed: simulated line fault", name_);
    *high = chip_.read_level(offset_);
    ++counters_.reads;
    return true;
  }

 private:
  SimGpioChip& chip_;
  unsigned offset_;
};

void SimGpioChip::Config::print(std::FILE* out) const {
  std::fprintf(out, "SimGpioChip::Config: name=%s num_lines=%u max_edges=%zu\n", name.c_str(), num_lines, max_edges);
}

SimGpioChip::SimGpioChip(Config config) : config_(std::move(config)), lines_(config_.num_lines) {
  edges_.reserve(config_.max_edges);
}

SimGpioChip::SimGpioChip() : SimGpioChip(Config()) {}

SimGpioChip::~SimGpioChip() = default;

std::unique_ptr<GpioLine> SimGpioChip::request(const GpioLineRequest& request, std::string* error) {
  if (request.offset >= config_.num_lines) {
    if (error) {
      *error = config_.name + ": line offset " + std::to_string(request.offset) + " out of range (the chip has " +
               std::to_string(config_.num_lines) + " lines)";
    }
    return nullptr;
  }
  Line& line = lines_[request.offset];
  if (line.requested) {
    if (error) {
      *error = config_.name + ": line " + std::to_string(request.offset) + " is busy (requested by '" +
               line.consumer + "')";
    }
    return nullptr;
  }
  line.requested = true;
  line.consumer = request.consumer;
  line.direction = request.direction;
  if (request.direction == GpioDirection::kOutput) drive(request.offset, request.initial_high, /*always_record=*/true);
  return std::make_unique<SimGpioLine>(*this, request.offset, request.direction);
}

bool SimGpioChip::script_input(unsigned offset, std::int64_t time_ns, bool high) {
  if (offset >= config_.num_lines) return false;
  std::vector<Change>& s = lines_[offset].script;
  if (!s.empty() && s.back().time_ns > time_ns) return false;
  s.push_back(Change{time_ns, high});
  return true;
}

void SimGpioChip::set_input_level(unsigned offset, bool high) {
  if (offset < config_.num_lines) lines_[offset].level = high;
}

void SimGpioChip::set_line_fault(unsigned offset, bool failing) {
  if (offset < config_.num_lines) lines_[offset].failing = failing;
}

bool SimGpioChip::level(unsigned offset) const { return offset < config_.num_lines && lines_[offset].level; }

bool SimGpioChip::is_requested(unsigned offset) const {
  return offset < config_.num_lines && lines_[offset].requested;
}

bool SimGpioChip::read_level(unsigned offset) {
  Line& line = lines_[offset];
  if (line.direction == GpioDirection::kInput) {
    while (line.next_change < line.script.size() && line.script[line.next_change].time_ns <= now_ns_) {
      line.level = line.script[line.next_change++].high;
    }
  }
  return line.level;
}

void SimGpioChip::drive(unsigned offset, bool high, bool always_record) {
  Line& line = lines_[offset];
  const bool edge = line.level != high || always_record;
  line.level = high;
  if (!edge) return;
  if (edges_.size() < config_.max_edges) {
    edges_.push_back(GpioEdge{offset, now_ns_, high});
  } else {
    ++edges_dropped_;
  }
}

}  // namespace qsg::gpio
