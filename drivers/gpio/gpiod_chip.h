// The libgpiod (v1 C API: Debian 11/12, JetPack) backend of the GPIO device class: a chip opened by name, path,
// label or number, lines requested by offset with a consumer string.
#pragma once

#include <memory>
#include <string>

#include "drivers/gpio/gpio_line.h"

struct gpiod_chip;

namespace qsg::gpio {

// True when this build has libgpiod (otherwise open() always fails and says so).
bool have_libgpiod();

class GpiodChip : public GpioChip {
 public:
  // `chip`: "gpiochip0", "/dev/gpiochip0", a label ("pl061") or a number ("0"). nullptr with *error when it is
  // missing or cannot be opened.
  static std::unique_ptr<GpiodChip> open(const std::string& chip, std::string* error);
  ~GpiodChip() override;
  GpiodChip(const GpiodChip&) = delete;
  GpiodChip& operator=(const GpiodChip&) = delete;

  const char* name() const override { return name_.c_str(); }
  unsigned num_lines() const override { return num_lines_; }
  std::unique_ptr<GpioLine> request(const GpioLineRequest& request, std::string* error) override;
  const std::string& label() const { return label_; }

 private:
  GpiodChip() = default;
  gpiod_chip* chip_ = nullptr;
  std::string name_;
  std::string label_;
  unsigned num_lines_ = 0;
};

}  // namespace qsg::gpio
