// The app's config reader (firmware_app/app_config) and its range check, and the app's fault-plan reader
// (firmware_app/fault_injection): any file loads or is refused with an error naming the file.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "firmware_app/app_config.h"
#include "firmware_app/fault_injection.h"
#include "fuzz/fuzz_support.h"

using namespace qsg;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = fuzz::scratch_path("config.json");
  fuzz::write_input(path, data, size);
  app::AppConfig config;
  std::string error;
  if (!config.load(path, &error)) {
    if (error.find(path) == std::string::npos) std::abort();  // errors name the file
  } else {
    (void)config.check();  // any loaded values: a message or "", never a trap
  }
  app::AppFaultPlan plan;
  error.clear();
  if (!app::parse_app_fault_plan(std::string(reinterpret_cast<const char*>(data), size), "<fuzz>", &plan, &error) &&
      error.empty())
    std::abort();
  return 0;
}
