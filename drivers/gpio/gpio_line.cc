// Names for GPIO enums.
#include "drivers/gpio/gpio_line.h"

namespace qsg::gpio {

const char* to_string(GpioDirection direction) {
  return direction == GpioDirection::kOutput ? "output" : "input";
}

}  // namespace qsg::gpio
