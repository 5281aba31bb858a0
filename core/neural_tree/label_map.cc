// The room classifier's label mapping (see label_map.h).
#include "core/neural_tree/label_map.h"

#include <cstring>

namespace qsg::neural_tree {
namespace {

using namespace semantics;

constexpr const char* kStructure = "structure, never an object";
constexpr const char* kClutter = "clutter the training rooms never show; it would only be read through its word vector";
constexpr const char* kCatchAll = "a catch-all class: says nothing about the room";
constexpr const char* kNoClass = "no training class names it; its word vector alone drifts the neural tree";

constexpr LabelReading kReadings[] = {
    {kVoid, "", kStructure},
    {kWall, "", kStructure},
    {kFloor, "", kStructure},
    {kChair, "chair", "same class"},
    {kDoor, "", kStructure},
    {kTable, "dining_table", "COCO's only table (desks included, as in mpcat40)"},
    {kPicture, "", kClutter},
    {kCabinet, "", kNoClass},
    {kCushion, "", kClutter},
    {kWindow, "", kStructure},
    {kSofa, "couch", "same object"},
    {kBed, "bed", "same class"},
    {kCurtain, "", kClutter},
    {kChestOfDrawers, "", kNoClass},
    {kPlant, "plant", "same class (COCO potted plant)"},
    {kSink, "sink", "same class"},
    {kStairs, "", kStructure},
    {kCeiling, "", kStructure},
    {kToilet, "toilet", "same class"},
    {kStool, "chair", "COCO files stools under chair"},
    {kTowel, "", kClutter},
    {kMirror, "", kClutter},
    {kTvMonitor, "tv", "same object"},
    {kShower, "", kNoClass},
    {kColumn, "", kStructure},
    {kBathtub, "", kNoClass},
    {kCounter, "", kNoClass},
    {kFireplace, "", kNoClass},
    {kLighting, "", kClutter},
    {kBeam, "", kStructure},
    {kRailing, "", kStructure},
    {kShelving, "", kNoClass},
    {kBlinds, "", kClutter},
    {kGymEquipment, "", kNoClass},
    {kSeating, "bench", "COCO bench: the seating that is not a chair or sofa"},
    {kBoardPanel, "", kClutter},
    {kFurniture, "", kCatchAll},
    {kAppliances, "appliances", "split by its box: refrigerator, oven or microwave (appliance_class)"},
    {kClothes, "", kClutter},
    {kObjects, "", kCatchAll},
    {kMisc, "", kCatchAll},
    {kUnlabeled, "", kStructure},
};
static_assert(sizeof(kReadings) / sizeof(kReadings[0]) == kNumObjectLabels, "one reading per mpcat40 label");

// Stanford3DSG classes (its object_labels order) and the mpcat40 label the app gives each.
struct StanfordLabel {
  const char* coco;
  Label mpcat40;
};
constexpr StanfordLabel kStanford[kNumStanfordClasses] = {
    {"bottle", kObjects},       {"toilet", kToilet},     {"sink", kSink},          {"plant", kPlant},
    {"vase", kObjects},         {"chair", kChair},       {"bed", kBed},            {"tv", kTvMonitor},
    {"skateboard", kObjects},   {"couch", kSofa},        {"dining_table", kTable}, {"handbag", kObjects},
    {"keyboard", kObjects},     {"book", kObjects},      {"clock", kObjects},      {"microwave", kAppliances},
    {"oven", kAppliances},      {"cup", kObjects},       {"bowl", kObjects},       {"refrigerator", kAppliances},
    {"cell_phone", kObjects},   {"laptop", kObjects},    {"bench", kSeating},      {"sports_ball", kObjects},
    {"backpack", kObjects},     {"tie", kClothes},       {"suitcase", kObjects},   {"wine_glass", kObjects},
    {"toaster", kAppliances},   {"apple", kObjects},     {"knife", kObjects},      {"teddy_bear", kObjects},
    {"remote", kObjects},       {"orange", kObjects},    {"bicycle", kObjects},
};

}  // namespace

const LabelReading& label_reading(Label label) {
  return label < kNumObjectLabels ? kReadings[label] : kReadings[kUnlabeled];
}

const char* appliance_class(const Eigen::Vector3d& size_m) {
  if (size_m.z() >= kFridgeMinHeightM) return "refrigerator";
  if (size_m.z() < kMicrowaveMaxHeightM) return "microwave";
  return "oven";
}

const char* classifier_class(Label label, const Eigen::Vector3d& size_m) {
  const char* reads = label_reading(label).reads_as;
  return std::strcmp(reads, "appliances") == 0 ? appliance_class(size_m) : reads;
}

Label mpcat40_from_stanford(const std::string& coco) {
  for (const StanfordLabel& s : kStanford)
    if (coco == s.coco) return s.mpcat40;
  return kInvalidLabel;
}

const char* stanford_class(int i) { return i >= 0 && i < kNumStanfordClasses ? kStanford[i].coco : ""; }

}  // namespace qsg::neural_tree
