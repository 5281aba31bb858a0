// libgpiod v1 backend; see gpiod_chip.h. Built without libgpiod, open() reports that instead.
#include "drivers/gpio/gpiod_chip.h"

#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>

#if QSG_HAVE_LIBGPIOD
#include <gpiod.h>
#endif

namespace qsg::gpio {

#if QSG_HAVE_LIBGPIOD

bool have_libgpiod() { return true; }

namespace {

class GpiodLine : public GpioLineBase {
 public:
  GpiodLine(gpiod_line* line, const char* chip_name, unsigned offset, GpioDirection direction)
      : GpioLineBase(chip_name, offset, direction), line_(line) {}
  ~GpiodLine() override { gpiod_line_release(line_); }

  bool set(bool high) override {
    if (!is_output()) return fail("%s: set() on a line requested as input", name_);
    if (gpiod_line_set_value(line_, high ? 1 : 0) < 0) return fail("%s: set failed: %s", name_, std::strerror(errno));
    ++counters_.writes;
    return true;
  }

  bool get(bool* high) override {
    const int v = gpiod_line_get_value(line_);
    if (v < 0) return fail("%s: get failed: %s", name_, std::strerror(errno));
    *high = v != 0;
    ++counters_.reads;
    return true;
  }

 private:
  gpiod_line* line_;
};

}  // namespace

std::unique_ptr<GpiodChip> GpiodChip::open(const std::string& chip, std::string* error) {
  errno = 0;
  gpiod_chip* c = gpiod_chip_open_lookup(chip.c_str());
  if (!c) {
    const int e = errno;
    if (error) {
      *error = "GPIO chip '" + chip + "' cannot be opened: " + (e ? std::strerror(e) : "not found") +
               " (give a name like gpiochip0, a path like /dev/gpiochip0, a label or a number)";
    }
    return nullptr;
  }
  std::unique_ptr<GpiodChip> result(new GpiodChip());
  result->chip_ = c;
  result->name_ = gpiod_chip_name(c);
  const char* label = gpiod_chip_label(c);
  result->label_ = label ? label : "";
  result->num_lines_ = gpiod_chip_num_lines(c);
  return result;
}

GpiodChip::~GpiodChip() {
  if (chip_) gpiod_chip_close(chip_);
}

std::unique_ptr<GpioLine> GpiodChip::request(const GpioLineRequest& request, std::string* error) {
  const std::string where = name_ + " (" + label_ + ") line " + std::to_string(request.offset);
  if (request.offset >= num_lines_) {
    if (error) *error = where + ": offset out of range (the chip has " + std::to_string(num_lines_) + " lines)";
    return nullptr;
  }
  gpiod_line* line = gpiod_chip_get_line(chip_, request.offset);
  if (!line) {
    if (error) *error = where + ": cannot get the line: " + std::strerror(errno);
    return nullptr;
  }
  if (gpiod_line_is_requested(line)) {
    if (error) *error = where + ": busy (already requested by this process)";
    return nullptr;
  }
  gpiod_line_update(line);  // refresh the kernel's view: another process may hold it now
  if (gpiod_line_is_used(line)) {
    const char* consumer = gpiod_line_consumer(line);
    if (error) *error = where + ": busy (used by '" + (consumer ? consumer : "the kernel") + "')";
    return nullptr;
  }
  const int r = request.direction == GpioDirection::kOutput
                    ? gpiod_line_request_output(line, request.consumer.c_str(), request.initial_high ? 1 : 0)
                    : gpiod_line_request_input(line, request.consumer.c_str());
  if (r < 0) {
    const int e = errno;
    if (error) {
      *error = where + ": request as " + to_string(request.direction) + " failed: " + std::strerror(e) +
               (e == EBUSY ? " (busy)" : "");
    }
    return nullptr;
  }
  return std::make_unique<GpiodLine>(line, name_.c_str(), request.offset, request.direction);
}

#else  // !QSG_HAVE_LIBGPIOD

bool have_libgpiod() { return false; }

std::unique_ptr<GpiodChip> GpiodChip::open(const std::string& chip, std::string* error) {
  if (error) *error = "GPIO chip '" + chip + "' cannot be opened: this build has no libgpiod (install libgpiod-dev)";
  return nullptr;
}

GpiodChip::~GpiodChip() = default;

std::unique_ptr<GpioLine> GpiodChip::request(const GpioLineRequest&, std::string* error) {
  if (error) *error = "this build has no libgpiod";
  return nullptr;
}

#endif

}  // namespace qsg::gpio
