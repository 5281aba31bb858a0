// The RGB-D source contract, run against the fault-injecting decorator over an in-memory camera.
#include <memory>

#include "drivers/sim/fault_plan.h"
#include "tests/drivers/rgbd_source_contract.h"
#include "tests/drivers/sim/memory_sources.h"

namespace qsg::testing {
namespace {

// Keeps the inner source alive as long as the decorator.
struct DecoratedMemoryCamera {
  DecoratedMemoryCamera(std::uint64_t frames, const sim::FaultPlan& plan) : inner(64, 48, frames), decorator(inner, plan) {}
  MemoryRgbdSource inner;
  sim::FaultInjectingRgbdSource decorator;
};

std::shared_ptr<drivers::RgbdSource> make_decorated(const char* plan_text, std::uint64_t frames, std::string* reason) {
  sim::FaultPlan plan;
  if (!sim::parse_fault_plan_text(plan_text, "contract plan", &plan, reason)) return nullptr;
  auto holder = std::make_shared<DecoratedMemoryCamera>(frames, plan);
  return std::shared_ptr<drivers::RgbdSource>(holder, &holder->decorator);
}

const char* const kEveryFault =
    "seed 11\nrate drop 0.05\nrate stall 0.05\nrate late 0.05\nrate backwards 0.05\nrate depth_nan 0.05\n"
    "rate depth_zero 0.05\nrate depth_saturated 0.05\nrate wrong_size 0.05\nrate unplug 0.02\n"
    "at 3 drop\nat 4 stall reads=2\nat 5 late\nat 6 backwards\nat 7 depth_saturated rect=0,0,8,8\n"
    "at 8 wrong_size\nat 9 unplug reads=3\n";

}  // namespace

INSTANTIATE_TEST_SUITE_P(
    FaultInjecting, RgbdSourceContract,
    ::testing::Values(RgbdContractCase{"no_faults",
                                       [](std::string* reason) { return make_decorated("", 30, reason); }},
                      RgbdContractCase{"every_fault",
                                       [](std::string* reason) { return make_decorated(kEveryFault, 60, reason); }},
                      RgbdContractCase{"endless_every_fault",
                                       [](std::string* reason) {
                                         return make_decorated(kEveryFault, 1'000'000'000ull, reason);
                                       },
                                       /*finite=*/false, /*max_reads=*/200}),
    rgbd_contract_case_name);

}  // namespace qsg::testing
