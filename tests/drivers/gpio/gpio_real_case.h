// The libgpiod contract case: runs when QSG_GPIO_CHIP (e.g. /dev/gpiochip0) and QSG_GPIO_LINE (an offset free to
// drive, e.g. 0 on the qemu virt board's PL061) are set, skips with the reason otherwise.
#pragma once

#include <cstdlib>
#include <memory>
#include <string>

#include "drivers/gpio/gpiod_chip.h"
#include "tests/drivers/gpio/gpio_line_contract.h"

namespace qsg::testing {

inline std::unique_ptr<gpio::GpioChip> make_real_gpio_chip(unsigned* offset, std::string* reason) {
  const char* chip = std::getenv("QSG_GPIO_CHIP");
  const char* line = std::getenv("QSG_GPIO_LINE");
  if (!chip || !*chip) {
    *reason = "QSG_GPIO_CHIP is not set; set QSG_GPIO_CHIP=/dev/gpiochip0 and QSG_GPIO_LINE=<offset> to run the "
              "GPIO contract on the real libgpiod backend";
    return nullptr;
  }
  if (!gpio::have_libgpiod()) {
    *reason = "this build has no libgpiod";
    return nullptr;
  }
  char* end = nullptr;
  const unsigned long v = line ? std::strtoul(line, &end, 10) : 0;
  if (line && (end == line || *end != '\0')) {
    *reason = std::string("QSG_GPIO_LINE='") + line + "' is not a line offset";
    return nullptr;
  }
  *offset = static_cast<unsigned>(v);
  std::string error;
  auto c = gpio::GpiodChip::open(chip, &error);
  if (!c) {
    // Asked for but not there: fail loudly instead of skipping.
    ADD_FAILURE() << error;
    *reason = error;
    return nullptr;
  }
  return c;
}

}  // namespace qsg::testing
