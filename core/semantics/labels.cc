// Label tables: the mpcat40 object and structure labels (Matterport3D) and the paper's room labels.
#include "core/semantics/labels.h"

#include <cstring>

namespace qsg::semantics {
namespace {

// mpcat40 index, name and colour, as published with Matterport3D (mpcat40.tsv).
constexpr LabelInfo kObjectLabels[] = {
    {0, "void", {255, 255, 255}},
    {1, "wall", {174, 199, 232}},
    {2, "floor", {112, 128, 144}},
    {3, "chair", {152, 223, 138}},
    {4, "door", {197, 176, 213}},
    {5, "table", {255, 127, 14}},
    {6, "picture", {214, 39, 40}},
    {7, "cabinet", {31, 119, 180}},
    {8, "cushion", {188, 189, 34}},
    {9, "window", {255, 152, 150}},
    {10, "sofa", {44, 160, 44}},
    {11, "bed", {227, 119, 194}},
    {12, "curtain", {222, 158, 214}},
    {13, "chest_of_drawers", {148, 103, 189}},
    {14, "plant", {140, 162, 82}},
    {15, "sink", {132, 60, 57}},
    {16, "stairs", {158, 218, 229}},
    {17, "ceiling", {156, 158, 222}},
    {18, "toilet", {231, 150, 156}},
    {19, "stool", {99, 121, 57}},
    {20, "towel", {140, 86, 75}},
    {21, "mirror", {219, 219, 141}},
    {22, "tv_monitor", {214, 97, 107}},
    {23, "shower", {206, 219, 156}},
    {24, "column", {231, 186, 82}},
    {25, "bathtub", {57, 59, 121}},
    {26, "counter", {165, 81, 148}},
    {27, "fireplace", {173, 73, 74}},
    {28, "lighting", {181, 207, 107}},
    {29, "beam", {82, 84, 163}},
    {30, "railing", {189, 158, 57}},
    {31, "shelving", {196, 156, 148}},
    {32, "blinds", {247, 182, 210}},
    {33, "gym_equipment", {107, 110, 207}},
    {34, "seating", {255, 187, 120}},
    {35, "board_panel", {199, 199, 199}},
    {36, "furniture", {140, 109, 49}},
    {37, "appliances", {231, 203, 148}},
    {38, "clothes", {206, 109, 189}},
    {39, "objects", {23, 190, 207}},
    {40, "misc", {127, 127, 127}},
    {41, "unlabeled", {0, 0, 0}},
};

// The room label space of the paper's appendix (from the Stanford 3D Scene Graph / Gibson room types).
constexpr const char* kRoomLabels[] = {
    "unknown", "bedroom", "closet", "dining room", "lobby", "family room", "garage", "hallway", "library",
    "laundry room", "kitchen", "living room", "conference room", "lounge", "office", "game room", "stairwell",
    "utility room", "theater", "gym", "balcony", "bar", "classroom", "dining booth", "spa", "bathroom",
};

}  // namespace

static_assert(sizeof(kObjectLabels) / sizeof(kObjectLabels[0]) == kNumObjectLabels, "mpcat40 has 42 entries");
static_assert(sizeof(kRoomLabels) / sizeof(kRoomLabels[0]) == kNumRoomLabels, "room label count");

const LabelInfo& object_label(Label label) {
  return label < kNumObjectLabels ? kObjectLabels[label] : kObjectLabels[kUnlabeled];
}

Label object_label_from_name(const char* name) {
  for (const LabelInfo& info : kObjectLabels)
    if (std::strcmp(info.name, name) == 0) return info.id;
  return kInvalidLabel;
}

bool is_structure(Label label) {
  switch (label) {
    case kVoid: case kWall: case kFloor: case kDoor: case kWindow: case kStairs: case kCeiling: case kColumn:
    case kBeam: case kRailing: case kUnlabeled:
      return true;
    default:
      return label >= kNumObjectLabels;
  }
}

const char* room_label_name(RoomLabel label) { return label < kNumRoomLabels ? kRoomLabels[label] : kRoomLabels[0]; }

RoomLabel room_label_from_name(const char* name) {
  for (RoomLabel i = 0; i < kNumRoomLabels; ++i)
    if (std::strcmp(kRoomLabels[i], name) == 0) return i;
  return kInvalidLabel;
}

}  // namespace qsg::semantics
