// The simulated chip's script and edge record, the device classes on top of it, and libgpiod's error path.
#include <gtest/gtest.h>

#include <string>

#include "drivers/gpio/gpio_devices.h"
#include "drivers/gpio/gpiod_chip.h"
#include "drivers/gpio/sim_gpio.h"
#include "tests/support/allocation_counter.h"

namespace qsg::testing {
namespace {

using gpio::GpioDirection;
using gpio::GpioLineRequest;
using gpio::SimGpioChip;

std::unique_ptr<gpio::GpioLine> request(SimGpioChip& chip, unsigned offset, GpioDirection direction,
                                        const char* consumer = "test") {
  GpioLineRequest r;
  r.offset = offset;
  r.direction = direction;
  r.consumer = consumer;
  std::string error;
  auto line = chip.request(r, &error);
  EXPECT_TRUE(line) << error;
  return line;
}

TEST(SimGpio, InputsFollowTheirScript) {
  SimGpioChip chip;
  ASSERT_TRUE(chip.script_input(2, 100, true));
  ASSERT_TRUE(chip.script_input(2, 250, false));
  EXPECT_FALSE(chip.script_input(2, 200, true)) << "a script goes forward in time";
  EXPECT_FALSE(chip.script_input(99, 0, true));
  auto in = request(chip, 2, GpioDirection::kInput);
  bool high = true;
  const std::int64_t times[] = {0, 99, 100, 249, 250, 1000};
  const bool expected[] = {false, false, true, true, false, false};
  for (int i = 0; i < 6; ++i) {
    chip.set_time_ns(times[i]);
    ASSERT_TRUE(in->get(&high));
    EXPECT_EQ(high, expected[i]) << "at " << times[i] << " ns";
  }
}

TEST(SimGpio, OutputsRecordEdgesWithTheirTime) {
  SimGpioChip chip;
  auto out = request(chip, 5, GpioDirection::kOutput);
  chip.set_time_ns(10);
  out->set(true);
  chip.set_time_ns(20);
  out->set(true);  // no change, no edge
  chip.set_time_ns(30);
  out->set(false);
  ASSERT_EQ(chip.edges().size(), 3u);
  EXPECT_EQ(chip.edges()[0].time_ns, 0);
  EXPECT_FALSE(chip.edges()[0].high) << "the requested level";
  EXPECT_EQ(chip.edges()[1].time_ns, 10);
  EXPECT_TRUE(chip.edges()[1].high);
  EXPECT_EQ(chip.edges()[2].time_ns, 30);
  EXPECT_EQ(chip.edges()[2].offset, 5u);
  EXPECT_TRUE(chip.is_requested(5));
  out.reset();
  EXPECT_FALSE(chip.is_requested(5));
}

TEST(SimGpio, EdgeRecordIsBoundedAndFaultsAreReported) {
  SimGpioChip::Config c;
  c.max_edges = 4;
  SimGpioChip chip(c);
  auto out = request(chip, 0, GpioDirection::kOutput);
  for (int i = 0; i < 10; ++i) out->set((i & 1) == 0);
  EXPECT_EQ(chip.edges().size(), 4u);
  EXPECT_EQ(chip.edges_dropped(), 7u);
  chip.set_line_fault(0, true);
  EXPECT_FALSE(out->set(true));
  EXPECT_NE(std::string(out->last_error()).find("sim-gpiochip0:0"), std::string::npos) << out->last_error();
  EXPECT_EQ(out->counters().errors, 1u);
}

TEST(GpioDevices, HeartbeatTogglesEveryTick) {
  SimGpioChip chip;
  auto line = request(chip, 1, GpioDirection::kOutput);
  gpio::Heartbeat heartbeat(*line);
  for (int tick = 0; tick < 6; ++tick) {
    chip.set_time_ns(tick * 100'000'000LL);
    ASSERT_TRUE(heartbeat.toggle());
  }
  EXPECT_EQ(heartbeat.toggles(), 6u);
  ASSERT_EQ(chip.edges().size(), 7u);  // the request, then one per tick
  for (int tick = 0; tick < 6; ++tick) {
    EXPECT_EQ(chip.edges()[tick + 1].high, tick % 2 == 0);
    EXPECT_EQ(chip.edges()[tick + 1].time_ns, tick * 100'000'000LL);
  }
  chip.set_line_fault(1, true);
  EXPECT_FALSE(heartbeat.toggle());
  EXPECT_EQ(heartbeat.failures(), 1u);
  EXPECT_FALSE(heartbeat.level()) << "the level did not change on failure";
}

TEST(GpioDevices, TriggerPulseHasItsWidth) {
  SimGpioChip chip;
  auto line = request(chip, 4, GpioDirection::kOutput);
  gpio::TriggerPulse trigger(*line, gpio::TriggerPulse::Config{2'000'000});
  chip.set_time_ns(1'000'000);
  ASSERT_TRUE(trigger.fire(chip.now_ns()));
  EXPECT_FALSE(trigger.fire(chip.now_ns())) << "no second pulse while high";
  EXPECT_EQ(trigger.overlapping(), 1u);
  chip.set_time_ns(2'500'000);
  trigger.update(chip.now_ns());
  EXPECT_TRUE(trigger.active());
  chip.set_time_ns(3'000'000);
  trigger.update(chip.now_ns());
  EXPECT_FALSE(trigger.active());
  ASSERT_EQ(chip.edges().size(), 3u);
  EXPECT_TRUE(chip.edges()[1].high);
  EXPECT_EQ(chip.edges()[2].time_ns - chip.edges()[1].time_ns, 2'000'000);
  EXPECT_EQ(trigger.pulses(), 1u);
}

TEST(GpioDevices, PauseSwitchIgnoresBounces) {
  SimGpioChip chip;
  // Pressed at 10 ms with 3 ms of bounce, released at 200 ms cleanly; a 5 ms glitch at 400 ms.
  const std::int64_t ms = 1'000'000;
  chip.script_input(6, 10 * ms, true);
  chip.script_input(6, 11 * ms, false);
  chip.script_input(6, 12 * ms, true);
  chip.script_input(6, 13 * ms, false);
  chip.script_input(6, 14 * ms, true);
  chip.script_input(6, 200 * ms, false);
  chip.script_input(6, 400 * ms, true);
  chip.script_input(6, 405 * ms, false);
  auto line = request(chip, 6, GpioDirection::kInput);
  gpio::PauseSwitch pause(*line, gpio::PauseSwitch::Config{20 * ms, true});
  bool paused_at_30 = false, paused_at_100 = false, paused_at_250 = true, paused_after_glitch = true;
  for (std::int64_t t = 0; t <= 600 * ms; t += ms) {  // a 1 kHz loop
    chip.set_time_ns(t);
    ASSERT_TRUE(pause.update(t));
    if (t == 30 * ms) paused_at_30 = pause.paused();
    if (t == 100 * ms) paused_at_100 = pause.paused();
    if (t == 250 * ms) paused_at_250 = pause.paused();
    if (t >= 401 * ms && t <= 430 * ms) paused_after_glitch = paused_after_glitch && !pause.paused();
  }
  EXPECT_FALSE(paused_at_30) << "14 ms + 20 ms debounce not yet over at 30 ms";
  EXPECT_TRUE(paused_at_100);
  EXPECT_FALSE(paused_at_250);
  EXPECT_TRUE(paused_after_glitch) << "a 5 ms glitch is not a press";
  EXPECT_EQ(pause.changes(), 2u);
  EXPECT_EQ(pause.bounces(), 3u) << "two bounces during the press and the glitch";
}

TEST(GpioDevices, TicksDoNotAllocate) {
  SimGpioChip chip;
  auto hb = request(chip, 0, GpioDirection::kOutput);
  auto trig = request(chip, 1, GpioDirection::kOutput);
  auto sw = request(chip, 2, GpioDirection::kInput);
  gpio::Heartbeat heartbeat(*hb);
  gpio::TriggerPulse trigger(*trig, gpio::TriggerPulse::Config{});
  gpio::PauseSwitch pause(*sw, gpio::PauseSwitch::Config{});
  EXPECT_NO_ALLOCATIONS(for (std::int64_t t = 0; t < 100'000'000; t += 5'000'000) {
    chip.set_time_ns(t);
    heartbeat.toggle();
    trigger.fire(t);
    trigger.update(t);
    pause.update(t);
  });
}

TEST(GpiodChip, AMissingChipIsAClearError) {
  std::string error;
  auto chip = gpio::GpiodChip::open("/dev/qsg-no-such-gpiochip", &error);
  EXPECT_FALSE(chip);
  EXPECT_NE(error.find("/dev/qsg-no-such-gpiochip"), std::string::npos) << error;
  EXPECT_NE(error.find("cannot be opened"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::testing
