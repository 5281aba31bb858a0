// Floor-plan importer's image reader (drivers/world/floor_plan_import): the size comes from the header and is
// bounded before anything is decoded; any file decodes within the limits or is refused with an error.
#include <cstdint>
#include <cstdlib>
#include <string>

#include <opencv2/core.hpp>

#include "drivers/world/floor_plan_import.h"
#include "fuzz/fuzz_support.h"

using namespace qsg;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = fuzz::scratch_path("plan.png");
  fuzz::write_input(path, data, size);
  world::FloorPlanConfig config;
  config.max_image_side_px = 1024;  // small limits keep each input fast; the check is the same
  config.max_image_pixels = 1024 * 1024;
  int width = 0, height = 0;
  std::string error;
  const bool sized = world::read_image_size(path, &width, &height, &error);
  cv::Mat grey;
  if (world::read_floor_plan_image(path, "occupancy", config, &grey, &error)) {
    if (!sized || grey.cols != width || grey.rows != height || grey.type() != CV_8UC1) std::abort();
    if (width > config.max_image_side_px || height > config.max_image_side_px) std::abort();
  } else if (error.empty() || error.find("but its header says") != std::string::npos) {
    std::abort();  // no error text, or the header reader and the decoder disagree (the size bound could be bypassed)
  }
  return 0;
}
