// Room-classifier weights reader (core/neural_tree/room_classifier): any file loads or is refused with an error.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/neural_tree/room_classifier.h"
#include "fuzz/fuzz_support.h"

using namespace qsg;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = fuzz::scratch_path("weights.json");
  fuzz::write_input(path, data, size);
  neural_tree::NeuralTreeWeights weights;
  std::string error;
  if (!neural_tree::load_weights(path, &weights, &error) && error.empty()) std::abort();
  return 0;
}
