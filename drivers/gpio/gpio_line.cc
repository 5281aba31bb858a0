// Names for GPIO enums and the part of a line every backend shares.
#include "drivers/gpio/gpio_line.h"

#include <cstdarg>
#include <cstdio>

namespace qsg::gpio {

const char* to_string(GpioDirection direction) {
  return direction == GpioDirection::kOutput ? "output" : "input";
}

GpioLineBase::GpioLineBase(const char* chip_name, unsigned offset, GpioDirection direction) : direction_(direction) {
  std::snprintf(name_, sizeof(name_), "%s:%u", chip_name, offset);
}

bool GpioLineBase::fail(const char* format, ...) {
  std::va_list args;
  va_start(args, format);
  std::vsnprintf(error_, sizeof(error_), format, args);
  va_end(args);
  ++counters_.errors;
  return false;
}

}  // namespace qsg::gpio
