// Semantic label spaces: mpcat40 labels for mesh vertices and objects (the paper's object labels are a subset),
// and the paper's room labels. A label is its index in the table.
#pragma once

#include <array>
#include <cstdint>

namespace qsg::semantics {

using Label = std::uint16_t;
using RoomLabel = std::uint16_t;
inline constexpr Label kInvalidLabel = 0xFFFF;

inline constexpr Label kNumObjectLabels = 42;
inline constexpr RoomLabel kNumRoomLabels = 26;

// mpcat40 indices used by name in code.
enum : Label {
  kVoid = 0, kWall = 1, kFloor = 2, kChair = 3, kDoor = 4, kTable = 5, kPicture = 6, kCabinet = 7, kCushion = 8,
  kWindow = 9, kSofa = 10, kBed = 11, kCurtain = 12, kChestOfDrawers = 13, kPlant = 14, kSink = 15, kStairs = 16,
  kCeiling = 17, kToilet = 18, kStool = 19, kTowel = 20, kMirror = 21, kTvMonitor = 22, kShower = 23, kColumn = 24,
  kBathtub = 25, kCounter = 26, kFireplace = 27, kLighting = 28, kBeam = 29, kRailing = 30, kShelving = 31,
  kBlinds = 32, kGymEquipment = 33, kSeating = 34, kBoardPanel = 35, kFurniture = 36, kAppliances = 37,
  kClothes = 38, kObjects = 39, kMisc = 40, kUnlabeled = 41,
};

// Room labels (index into the paper's room label space; 0 = unknown).
enum : RoomLabel {
  kRoomUnknown = 0, kBedroom = 1, kCloset = 2, kDiningRoom = 3, kLobby = 4, kFamilyRoom = 5, kGarage = 6,
  kHallway = 7, kLibrary = 8, kLaundryRoom = 9, kKitchen = 10, kLivingRoom = 11, kConferenceRoom = 12,
  kLounge = 13, kOffice = 14, kGameRoom = 15, kStairwell = 16, kUtilityRoom = 17, kTheater = 18, kGym = 19,
  kBalcony = 20, kBar = 21, kClassroom = 22, kDiningBooth = 23, kSpa = 24, kBathroom = 25,
};

struct LabelInfo {
  Label id;
  const char* name;
  std::array<std::uint8_t, 3> color;
};

const LabelInfo& object_label(Label label);
Label object_label_from_name(const char* name);  // kInvalidLabel when unknown
// Structure (wall, floor, ceiling, door, window, stairs, ...) never becomes an object.
bool is_structure(Label label);

const char* room_label_name(RoomLabel label);
RoomLabel room_label_from_name(const char* name);  // kInvalidLabel when unknown

}  // namespace qsg::semantics
