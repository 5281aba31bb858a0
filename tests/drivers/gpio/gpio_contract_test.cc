// The GPIO contract on the simulated chip (always) and on libgpiod (when QSG_GPIO_CHIP / QSG_GPIO_LINE are set).
#include <memory>

#include "drivers/gpio/sim_gpio.h"
#include "tests/drivers/gpio/gpio_line_contract.h"
#include "tests/drivers/gpio/gpio_real_case.h"

namespace qsg::testing {

INSTANTIATE_TEST_SUITE_P(
    Gpio, GpioLineContract,
    ::testing::Values(GpioContractCase{"sim",
                                       [](unsigned* offset, std::string*) -> std::unique_ptr<gpio::GpioChip> {
                                         *offset = 3;
                                         return std::make_unique<gpio::SimGpioChip>();
                                       }},
                      GpioContractCase{"libgpiod", make_real_gpio_chip}),
    gpio_contract_case_name);

}  // namespace qsg::testing
