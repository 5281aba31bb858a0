// Procedural building generator: corridor-and-strips layout per floor, doors from a spanning set plus extras,
// half-thickness walls per room with door gaps, floors/ceilings, stairs, and room-type-dependent furniture.
#include "drivers/world/building_generator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>

#include "drivers/world/world_geometry.h"
#include "drivers/world/world_query.h"

namespace qsg::world {
namespace {

using semantics::Label;
using semantics::RoomLabel;
constexpr double kPi = 3.14159265358979323846;

// Stair geometry: a straight flight along the stairwell's west wall, with landings at both ends.
constexpr double kStairWidthM = 1.0;
constexpr double kStairTreadM = 0.25;
constexpr double kStairMaxRiseM = 0.2;
constexpr double kStairLandingM = 0.9;
constexpr double kStairwellWidthM = 3.2;
constexpr double kRailingThicknessM = 0.04;
constexpr double kRailingHeightM = 0.9;
constexpr double kMinFrontDepthM = 3.0;  // a room split in depth keeps this much at the corridor
constexpr double kMinRoomWidthM = 1.5;

struct RoomPlan {
  RoomLabel label = semantics::kRoomUnknown;
  Rect rect;
  int floor = 0;
};

// A door lies on a line x = c (axis 0, span along y) or y = c (axis 1, span along x).
struct DoorPlan {
  int axis = 1;
  double c = 0.0;
  Interval span;
  int room_a = -1, room_b = -1;
  int floor = 0;
  bool in_wall = true;  // false for the stair top, which is not cut into any wall
};

struct Segment {
  int side = 1;  // +1 north strip, -1 south strip
  double width = 0.0;
  RoomLabel front = semantics::kRoomUnknown;
  RoomLabel back = semantics::kRoomUnknown;  // kRoomUnknown: no back room
  double back_depth = 0.0;
};

struct FloorLayout {
  double length_m = 0.0;
  int hallways = 1;
  std::vector<Segment> segments;  // north ones in x order, then south ones in x order
};

struct Shell {
  double hallway_width_m = 1.6;
  double north_depth_m = 4.0;
  double south_depth_m = 4.0;
  double stairwell_width_m = 0.0;
};

BuildingConfig clamped(const BuildingConfig& in) {
  BuildingConfig c = in;
  c.room_size_min_m = std::max(c.room_size_min_m, 2.5);
  c.room_size_max_m = std::max(c.room_size_max_m, c.room_size_min_m);
  c.ceiling_height_m = std::max(c.ceiling_height_m, 2.2);
  c.wall_thickness_m = std::clamp(c.wall_thickness_m, 0.02, 0.4);
  c.door_width_min_m = std::max(c.door_width_min_m, 0.6);
  c.door_width_max_m = std::max(c.door_width_max_m, c.door_width_min_m);
  c.door_height_m = std::clamp(c.door_height_m, 1.8, c.ceiling_height_m);
  c.hallway_width_min_m = std::max(c.hallway_width_min_m, c.door_width_min_m + 0.4 + c.wall_thickness_m);
  c.hallway_width_max_m = std::max(c.hallway_width_max_m, c.hallway_width_min_m);
  c.max_hallway_length_m = std::max(c.max_hallway_length_m, 2.0 * c.room_size_max_m);
  c.slab_thickness_m = std::clamp(c.slab_thickness_m, 0.05, 1.0);
  c.num_rooms = std::max(c.num_rooms, c.two_floors ? 8 : 3);
  c.robot_clearance_m = std::clamp(c.robot_clearance_m, 0.0, 0.4);
  return c;
}

// ---- room types ----

struct Weighted {
  RoomLabel label;
  int weight;
};

RoomLabel pick(Rng& rng, const std::vector<Weighted>& table) {
  int total = 0;
  for (const Weighted& w : table) total += w.weight;
  int r = rng.uniform_int(0, total - 1);
  for (const Weighted& w : table) {
    if (r < w.weight) return w.label;
    r -= w.weight;
  }
  return table.back().label;
}

// Front-room types of a floor: the must-haves first (in shuffled order), then weighted draws.
std::vector<RoomLabel> front_type_bag(Rng& rng, int floor, bool two_floors, int count) {
  using namespace semantics;
  const std::vector<RoomLabel> required =
      floor > 0    ? std::vector<RoomLabel>{kBedroom, kBathroom, kBedroom, kOffice}
      : two_floors ? std::vector<RoomLabel>{kKitchen, kLivingRoom, kBathroom, kDiningRoom, kOffice}
                   : std::vector<RoomLabel>{kKitchen, kLivingRoom, kBathroom, kBedroom, kDiningRoom, kOffice};
  const std::vector<Weighted> table =
      floor > 0 ? std::vector<Weighted>{{kBedroom, 4}, {kBathroom, 2}, {kOffice, 2}, {kLaundryRoom, 1}, {kCloset, 1}}
                : std::vector<Weighted>{{kBedroom, 3},     {kOffice, 2},     {kBathroom, 2}, {kDiningRoom, 1},
                                        {kLaundryRoom, 1}, {kLivingRoom, 1}, {kCloset, 1}};
  std::vector<RoomLabel> bag;
  for (int i = 0; i < count; ++i) bag.push_back(i < static_cast<int>(required.size()) ? required[i] : pick(rng, table));
  for (int i = count - 1; i > 0; --i) std::swap(bag[i], bag[rng.uniform_int(0, i)]);
  return bag;
}

std::vector<Weighted> annex_types(RoomLabel front) {
  using namespace semantics;
  switch (front) {
    case kBedroom: return {{kCloset, 2}, {kBathroom, 2}};
    case kKitchen: return {{kLaundryRoom, 1}, {kCloset, 1}};
    case kLivingRoom: return {{kOffice, 1}, {kDiningRoom, 1}};
    case kOffice: return {{kCloset, 1}};
    default: return {};
  }
}

double nominal_size(Rng& rng, RoomLabel label, const BuildingConfig& c) {
  switch (label) {
    case semantics::kCloset: return rng.uniform(1.5, 2.2);
    case semantics::kBathroom:
    case semantics::kLaundryRoom: return rng.uniform(2.2, 3.0);
    default: return rng.uniform(c.room_size_min_m, c.room_size_max_m);
  }
}

// ---- layout ----

FloorLayout plan_floor(Rng& rng, const BuildingConfig& c, const Shell& shell, int floor, int target_rooms,
                       double fixed_length_m) {
  const int stairs = c.two_floors ? 1 : 0;
  int hallways = 1;
  if (fixed_length_m > 0.0) {
    hallways = static_cast<int>(std::ceil(fixed_length_m / c.max_hallway_length_m - 1e-9));
    hallways = std::max(1, std::min(hallways, target_rooms - stairs - 2));
  }
  for (int attempt = 0;; ++attempt) {
    Rng r = rng.fork(static_cast<std::uint64_t>(attempt) + 1);
    const int k = std::max(2, target_rooms - stairs - hallways);
    std::vector<RoomLabel> bag = front_type_bag(r, floor, c.two_floors, k);
    FloorLayout layout;
    layout.hallways = hallways;
    std::array<double, 2> length{{0.0, shell.stairwell_width_m}};  // [south, north]
    std::array<int, 2> count{{0, 0}};
    int used = 0;
    std::size_t next_type = 0;
    while (used < k) {
      // Each side gets a room before the balancing starts, so no side is left empty.
      int s = count[1] == 0 ? 1 : count[0] == 0 ? 0 : (length[0] < length[1] ? 0 : 1);
      Segment seg;
      seg.side = s == 1 ? 1 : -1;
      seg.front = next_type < bag.size() ? bag[next_type++] : static_cast<RoomLabel>(semantics::kBedroom);
      seg.width = nominal_size(r, seg.front, c);
      const double depth = s == 1 ? shell.north_depth_m : shell.south_depth_m;
      const int empty_after = (count[0] == 0 && s != 0 ? 1 : 0) + (count[1] == 0 && s != 1 ? 1 : 0);
      const std::vector<Weighted> annex = annex_types(seg.front);
      if (!annex.empty() && k - used - 2 >= empty_after && r.chance(c.annex_probability)) {
        const RoomLabel back = pick(r, annex);
        // Both parts stay big enough for their furniture: the front room at least 3 m deep.
        const double back_min = back == semantics::kCloset ? 1.5 : back == semantics::kLaundryRoom ? 2.0 : 2.5;
        const double back_depth = std::min(std::max(nominal_size(r, back, c), back_min), depth - kMinFrontDepthM);
        if (back_depth >= back_min) {
          seg.back = back;
          seg.back_depth = back_depth;
          seg.width = std::max(seg.width, 2.8);
        }
      }
      used += seg.back != semantics::kRoomUnknown ? 2 : 1;
      length[s] += seg.width;
      ++count[s];
      layout.segments.push_back(seg);
    }
    double total = std::max(length[0], length[1]);
    if (fixed_length_m <= 0.0 && total > c.max_hallway_length_m * hallways &&
        target_rooms - stairs - hallways - 1 >= 2) {
      ++hallways;
      continue;
    }
    if (fixed_length_m > 0.0) total = fixed_length_m;
    // Stretch each side's rooms so both strips end where the corridor ends.
    for (int s = 0; s < 2; ++s) {
      double sum = 0.0;
      for (const Segment& seg : layout.segments)
        if ((seg.side == 1) == (s == 1)) sum += seg.width;
      const double target = total - (s == 1 ? shell.stairwell_width_m : 0.0);
      if (sum <= 0.0) continue;
      for (Segment& seg : layout.segments)
        if ((seg.side == 1) == (s == 1)) seg.width *= target / sum;
    }
    // Squeezing (upper floors have a fixed length) must leave every room wide enough for a door and furniture.
    bool too_narrow = false;
    for (const Segment& seg : layout.segments) too_narrow = too_narrow || seg.width < kMinRoomWidthM;
    if (too_narrow && attempt < 64) continue;
    std::stable_sort(layout.segments.begin(), layout.segments.end(),
                     [](const Segment& a, const Segment& b) { return a.side > b.side; });
    layout.length_m = total;
    return layout;
  }
}

bool shared_edge(const Rect& a, const Rect& b, int* axis, double* c, Interval* span) {
  auto overlap = [](double a0, double a1, double b0, double b1) {
    return Interval{std::max(a0, b0), std::min(a1, b1)};
  };
  if (std::abs(a.y1 - b.y0) < 1e-6 || std::abs(a.y0 - b.y1) < 1e-6) {
    *axis = 1;
    *c = std::abs(a.y1 - b.y0) < 1e-6 ? a.y1 : a.y0;
    *span = overlap(a.x0, a.x1, b.x0, b.x1);
    if (span->length() > 0.0) return true;
  }
  if (std::abs(a.x1 - b.x0) < 1e-6 || std::abs(a.x0 - b.x1) < 1e-6) {
    *axis = 0;
    *c = std::abs(a.x1 - b.x0) < 1e-6 ? a.x1 : a.x0;
    *span = overlap(a.y0, a.y1, b.y0, b.y1);
    if (span->length() > 0.0) return true;
  }
  return false;
}

// ---- materials ----

using Rgb = std::array<std::uint8_t, 3>;

Rgb jitter(Rng& rng, const Rgb& base, int amount) {
  Rgb out;
  for (int i = 0; i < 3; ++i)
    out[i] = static_cast<std::uint8_t>(std::clamp(base[i] + rng.uniform_int(-amount, amount), 0, 255));
  return out;
}

Material material(Label label, const Rgb& color, Texture texture = Texture::kPlain, float scale_m = 0.25f) {
  Material m;
  m.label = label;
  m.color = color;
  m.texture = texture;
  m.texture_scale_m = scale_m;
  return m;
}

Rgb pick_color(Rng& rng, const std::vector<Rgb>& palette, int amount = 12) {
  return jitter(rng, palette[static_cast<std::size_t>(rng.uniform_int(0, static_cast<int>(palette.size()) - 1))],
                amount);
}

const std::vector<Rgb> kWood = {{150, 111, 51}, {193, 154, 107}, {111, 78, 55}, {222, 184, 135}, {160, 82, 45}};
const std::vector<Rgb> kWhite = {{240, 240, 235}, {225, 225, 220}, {245, 245, 245}};
const std::vector<Rgb> kFabric = {{70, 90, 140},   {140, 60, 60}, {90, 120, 80},
                                  {180, 170, 150}, {60, 60, 60},  {200, 150, 90}};
const std::vector<Rgb> kMetal = {{190, 190, 195}, {120, 120, 125}, {235, 235, 235}, {40, 40, 45}};
const std::vector<Rgb> kWallPaint = {{235, 230, 220}, {220, 225, 235}, {240, 235, 200}, {210, 230, 215},
                                     {245, 220, 215}, {230, 230, 230}, {200, 215, 230}};

struct RoomLook {
  Material wall, floor, ceiling;
};

RoomLook room_look(Rng& rng, RoomLabel label) {
  using namespace semantics;
  // One draw per statement: the order in which a call's arguments are evaluated differs between compilers.
  RoomLook look;
  const double t = rng.uniform();
  const Texture wall_tex = t < 0.6 ? Texture::kPlain : t < 0.85 ? Texture::kNoise : Texture::kStripes;
  const Rgb wall_color = pick_color(rng, kWallPaint);
  look.wall = material(kWall, wall_color, wall_tex, static_cast<float>(rng.uniform(0.1, 0.4)));
  switch (label) {
    case kBathroom:
    case kKitchen:
    case kLaundryRoom: {
      const Rgb tiles = pick_color(rng, {{200, 200, 205}, {180, 170, 160}, {230, 225, 215}});
      look.floor = material(kFloor, tiles, Texture::kChecker, static_cast<float>(rng.uniform(0.2, 0.4)));
      break;
    }
    case kHallway:
    case kStairwell:
      look.floor = material(kFloor, pick_color(rng, {{150, 150, 150}, {120, 110, 100}}), Texture::kNoise, 0.2f);
      break;
    default:
      if (rng.chance(0.6)) {
        const Rgb wood = pick_color(rng, kWood);
        look.floor = material(kFloor, wood, Texture::kStripes, static_cast<float>(rng.uniform(0.1, 0.2)));
      } else {
        look.floor = material(kFloor, pick_color(rng, kFabric, 20), Texture::kNoise, 0.1f);
      }
  }
  look.ceiling = material(kCeiling, jitter(rng, {245, 245, 240}, 5));
  return look;
}

// ---- furniture ----

enum class Mode : std::uint8_t { kWall, kCorner, kCenter, kAround, kFront, kOnTop };

struct Item {
  Label label;
  Eigen::Vector3d size_m;  // x along the wall / width, y depth (front is +y), z height
  Mode mode;
  int parent = -1;  // index into the room's item list (kAround, kFront, kOnTop)
  bool required = false;
  double gap_m = 0.05;  // kFront: distance to the parent
};

Eigen::Vector3d dims(Rng& r, double w0, double w1, double d0, double d1, double h0, double h1) {
  return {r.uniform(w0, w1), r.uniform(d0, d1), r.uniform(h0, h1)};
}

std::vector<Item> furniture_for(Rng& r, RoomLabel room) {
  using namespace semantics;
  std::vector<Item> items;
  auto add = [&](Label l, const Eigen::Vector3d& s, Mode m, bool required = false, int parent = -1, double gap = 0.05) {
    items.push_back({l, s, m, parent, required, gap});
    return static_cast<int>(items.size()) - 1;
  };
  switch (room) {
    case kKitchen: {
      add(kAppliances, dims(r, 0.7, 0.8, 0.65, 0.72, 1.7, 1.9), Mode::kCorner, true);  // refrigerator
      add(kSink, dims(r, 0.6, 0.8, 0.55, 0.6, 0.88, 0.92), Mode::kWall, true);
      add(kAppliances, dims(r, 0.58, 0.62, 0.58, 0.62, 0.88, 0.92), Mode::kWall, true);  // stove
      add(kCabinet, dims(r, 0.6, 1.0, 0.45, 0.6, 0.9, 2.0), Mode::kWall, true);
      if (r.chance(0.7)) add(kCounter, dims(r, 1.0, 1.6, 0.6, 0.65, 0.88, 0.92), Mode::kWall);
      const int table = add(kTable, dims(r, 0.8, 1.2, 0.7, 0.8, 0.73, 0.77), Mode::kCenter, true);
      for (int i = 0, n = r.uniform_int(1, 3); i < n; ++i)
        add(kChair, dims(r, 0.42, 0.48, 0.42, 0.48, 0.85, 0.95), Mode::kAround, false, table);
      break;
    }
    case kBedroom: {
      add(kBed, dims(r, 1.4, 1.8, 1.95, 2.1, 0.9, 1.0), Mode::kWall, true);
      add(kChestOfDrawers, dims(r, 0.8, 1.2, 0.45, 0.5, 0.8, 1.0), Mode::kWall, true);
      if (r.chance(0.6)) add(kCabinet, dims(r, 1.0, 1.5, 0.55, 0.62, 1.9, 2.1), Mode::kWall);
      if (r.chance(0.5)) add(kPlant, dims(r, 0.35, 0.5, 0.35, 0.5, 0.6, 1.3), Mode::kCorner);
      if (r.chance(0.4)) add(kChair, dims(r, 0.42, 0.48, 0.42, 0.48, 0.85, 0.95), Mode::kWall);
      break;
    }
    case kBathroom: {
      add(kBathtub, dims(r, 1.5, 1.7, 0.7, 0.8, 0.52, 0.58), Mode::kCorner, true);
      add(kToilet, dims(r, 0.38, 0.42, 0.62, 0.7, 0.75, 0.8), Mode::kWall, true);
      add(kSink, dims(r, 0.5, 0.7, 0.42, 0.48, 0.83, 0.88), Mode::kWall, true);
      if (r.chance(0.4)) add(kCabinet, dims(r, 0.4, 0.6, 0.3, 0.4, 0.6, 1.8), Mode::kWall);
      break;
    }
    case kOffice: {
      const int desk = add(kTable, dims(r, 1.2, 1.6, 0.7, 0.8, 0.73, 0.77), Mode::kWall, true);
      add(kChair, dims(r, 0.5, 0.6, 0.5, 0.6, 0.95, 1.1), Mode::kFront, true, desk, 0.1);
      add(kTvMonitor, dims(r, 0.5, 0.65, 0.18, 0.22, 0.38, 0.48), Mode::kOnTop, true, desk);
      add(kShelving, dims(r, 0.8, 1.2, 0.35, 0.4, 1.8, 2.0), Mode::kWall, true);
      if (r.chance(0.5)) add(kCabinet, dims(r, 0.5, 0.9, 0.45, 0.6, 0.7, 1.3), Mode::kWall);
      if (r.chance(0.5)) add(kPlant, dims(r, 0.35, 0.5, 0.35, 0.5, 0.6, 1.3), Mode::kCorner);
      break;
    }
    case kLivingRoom: {
      const int sofa = add(kSofa, dims(r, 1.8, 2.3, 0.85, 0.95, 0.78, 0.85), Mode::kWall, true);
      add(kTable, dims(r, 0.8, 1.1, 0.5, 0.6, 0.4, 0.48), Mode::kFront, true, sofa, 0.35);  // coffee table
      const int stand = add(kCabinet, dims(r, 1.2, 1.6, 0.4, 0.45, 0.45, 0.55), Mode::kWall, true);
      add(kTvMonitor, dims(r, 1.0, 1.25, 0.2, 0.25, 0.6, 0.75), Mode::kOnTop, true, stand);
      add(kPlant, dims(r, 0.4, 0.55, 0.4, 0.55, 0.8, 1.5), Mode::kCorner, true);
      if (r.chance(0.5)) add(kShelving, dims(r, 0.8, 1.2, 0.35, 0.4, 1.6, 2.0), Mode::kWall);
      if (r.chance(0.5)) add(kChair, dims(r, 0.7, 0.85, 0.75, 0.85, 0.8, 0.95), Mode::kWall);  // armchair
      break;
    }
    case kDiningRoom: {
      const int table = add(kTable, dims(r, 1.4, 1.8, 0.85, 1.0, 0.73, 0.77), Mode::kCenter, true);
      for (int i = 0, n = r.uniform_int(3, 6); i < n; ++i)
        add(kChair, dims(r, 0.42, 0.48, 0.42, 0.48, 0.85, 0.95), Mode::kAround, i < 2, table);
      if (r.chance(0.6)) add(kCabinet, dims(r, 1.2, 1.6, 0.45, 0.5, 0.8, 0.95), Mode::kWall);
      if (r.chance(0.5)) add(kPlant, dims(r, 0.35, 0.5, 0.35, 0.5, 0.6, 1.3), Mode::kCorner);
      break;
    }
    case kCloset: {
      add(kShelving, dims(r, 0.8, 1.2, 0.35, 0.45, 1.8, 2.1), Mode::kWall, true);
      if (r.chance(0.6)) add(kShelving, dims(r, 0.6, 1.0, 0.35, 0.45, 1.8, 2.1), Mode::kWall);
      if (r.chance(0.4)) add(kCabinet, dims(r, 0.5, 0.8, 0.4, 0.5, 0.8, 1.2), Mode::kWall);
      break;
    }
    case kLaundryRoom: {
      add(kAppliances, dims(r, 0.58, 0.62, 0.58, 0.62, 0.84, 0.88), Mode::kWall, true);  // washer
      add(kAppliances, dims(r, 0.58, 0.62, 0.58, 0.62, 0.84, 0.88), Mode::kWall, true);  // dryer
      add(kSink, dims(r, 0.5, 0.7, 0.45, 0.55, 0.85, 0.9), Mode::kWall, true);
      if (r.chance(0.6)) add(kShelving, dims(r, 0.6, 1.0, 0.3, 0.4, 1.6, 1.9), Mode::kWall);
      break;
    }
    case kHallway: {
      if (r.chance(0.6)) add(kPlant, dims(r, 0.35, 0.45, 0.35, 0.45, 0.6, 1.2), Mode::kCorner);
      break;
    }
    default: break;
  }
  // Required items are placed first, so optional ones never take their space; parents are always required
  // when their children are, so re-indexing parents after the stable partition is enough.
  std::vector<int> order(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_partition(order.begin(), order.end(), [&](int i) { return items[static_cast<std::size_t>(i)].required; });
  std::vector<int> new_index(items.size());
  for (std::size_t k = 0; k < order.size(); ++k) new_index[static_cast<std::size_t>(order[k])] = static_cast<int>(k);
  std::vector<Item> sorted;
  for (int i : order) {
    Item item = items[static_cast<std::size_t>(i)];
    if (item.parent >= 0) item.parent = new_index[static_cast<std::size_t>(item.parent)];
    sorted.push_back(item);
  }
  return sorted;
}

// Renders one object as parts inside its oriented box (local frame: centre at origin, front +y, up +z).
class PartBuilder {
 public:
  PartBuilder(World& world, const Object& object) : world_(world), object_(object) {
    R_ = object.box.world_R_box.toRotationMatrix();
    h_ = object.box.half_extents_m;
  }
  const Eigen::Vector3d& h() const { return h_; }
  void box(double x0, double y0, double z0, double x1, double y1, double z1, const Material& m) {
    BoxShape b;
    b.center_m = object_.box.center_m + rotate(R_, Eigen::Vector3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1)));
    b.half_extents_m = 0.5 * Eigen::Vector3d(std::abs(x1 - x0), std::abs(y1 - y0), std::abs(z1 - z0));
    b.world_R_box = object_.box.world_R_box;
    world_.add_box(b, m, object_.id, object_.room_id);
  }
  void cylinder(double x, double y, double z0, double radius, double height, const Material& m) {
    CylinderShape c;
    c.base_center_m = object_.box.center_m + rotate(R_, Eigen::Vector3d(x, y, z0));
    c.radius_m = radius;
    c.height_m = height;
    world_.add_cylinder(c, m, object_.id, object_.room_id);
  }

 private:
  World& world_;
  const Object& object_;
  Eigen::Matrix3d R_;
  Eigen::Vector3d h_;
};

void render_object(World& world, const Object& object, Rng& rng) {
  using namespace semantics;
  PartBuilder p(world, object);
  const double hx = p.h().x(), hy = p.h().y(), hz = p.h().z();
  const Label l = object.label;
  const Texture grain = rng.chance(0.5) ? Texture::kStripes : Texture::kPlain;
  switch (l) {
    case kTable: {
      const Material m = material(l, pick_color(rng, kWood), grain, 0.08f);
      const double leg = 0.05, in = 0.03;
      p.box(-hx, -hy, hz - 0.04, hx, hy, hz, m);
      for (int sx : {-1, 1})
        for (int sy : {-1, 1})
          p.box(sx * (hx - in), sy * (hy - in), -hz, sx * (hx - in - leg), sy * (hy - in - leg), hz - 0.04, m);
      break;
    }
    case kChair: {
      const bool armchair = hx > 0.3;
      const Material m = material(l, armchair ? pick_color(rng, kFabric) : pick_color(rng, kWood),
                                  armchair ? Texture::kNoise : grain, 0.08f);
      if (armchair) {
        p.box(-hx, -hy, -hz, hx, hy, -hz + 0.42, m);
        p.box(-hx, -hy, -hz + 0.42, hx, -hy + 0.18, hz, m);
        break;
      }
      const double seat = -hz + 0.46;
      p.box(-hx, -hy, seat - 0.05, hx, hy, seat, m);
      p.box(-hx, -hy, seat, hx, -hy + 0.05, hz, m);
      for (int sx : {-1, 1})
        for (int sy : {-1, 1}) p.box(sx * hx, sy * hy, -hz, sx * (hx - 0.04), sy * (hy - 0.04), seat - 0.05, m);
      break;
    }
    case kBed: {
      const Material frame = material(l, pick_color(rng, kWood), grain, 0.08f);
      const Material sheet = material(l, pick_color(rng, kFabric, 25), Texture::kNoise, 0.1f);
      p.box(-hx, -hy + 0.06, -hz, hx, hy, -hz + 0.3, frame);
      p.box(-hx + 0.03, -hy + 0.08, -hz + 0.3, hx - 0.03, hy - 0.03, -hz + 0.52, sheet);
      p.box(-hx, -hy, -hz, hx, -hy + 0.06, hz, frame);
      break;
    }
    case kSofa: {
      const Material m = material(l, pick_color(rng, kFabric), Texture::kNoise, 0.05f);
      p.box(-hx, -hy, -hz, hx, hy, -hz + 0.42, m);
      p.box(-hx, -hy, -hz + 0.42, hx, -hy + 0.2, hz, m);
      p.box(-hx, -hy + 0.2, -hz + 0.42, -hx + 0.15, hy, -hz + 0.62, m);
      p.box(hx - 0.15, -hy + 0.2, -hz + 0.42, hx, hy, -hz + 0.62, m);
      break;
    }
    case kPlant: {
      const double r = std::min(hx, hy);
      const double pot_h = 0.35 * 2.0 * hz;
      p.cylinder(0.0, 0.0, -hz, 0.6 * r, pot_h, material(l, jitter(rng, {170, 90, 50}, 15)));
      p.cylinder(0.0, 0.0, -hz + pot_h, 0.98 * r, 2.0 * hz - pot_h,
                 material(l, pick_color(rng, {{50, 120, 50}, {80, 140, 60}, {40, 100, 70}}), Texture::kNoise, 0.05f));
      break;
    }
    case kToilet: {
      const Material m = material(l, pick_color(rng, kWhite, 5));
      p.box(-hx, -hy, -hz + 0.35, hx, -hy + 0.2, hz, m);
      const double r = std::min(hx, hy - 0.1);
      p.cylinder(0.0, hy - r, -hz, r, 0.42, m);
      break;
    }
    case kTvMonitor: {
      const Material m = material(l, jitter(rng, {25, 25, 30}, 5));
      p.box(-0.3 * hx, -hy, -hz, 0.3 * hx, hy, -hz + 0.03, m);
      p.box(-0.05, -0.03, -hz, 0.05, 0.03, -hz + 0.4 * hz, m);
      p.box(-hx, -0.03, -hz + 0.4 * hz, hx, 0.03, hz, m);
      break;
    }
    case kShelving: {
      const Material m = material(l, pick_color(rng, rng.chance(0.7) ? kWood : kWhite), grain, 0.08f);
      p.box(-hx, -hy, -hz, -hx + 0.03, hy, hz, m);
      p.box(hx - 0.03, -hy, -hz, hx, hy, hz, m);
      p.box(-hx, -hy, -hz, hx, -hy + 0.02, hz, m);
      const int shelves = rng.uniform_int(4, 5);
      for (int i = 0; i < shelves; ++i) {
        const double z = -hz + (2.0 * hz - 0.025) * i / (shelves - 1);
        p.box(-hx + 0.03, -hy + 0.02, z, hx - 0.03, hy, z + 0.025, m);
      }
      break;
    }
    case kBathtub: {
      const Material m = material(l, pick_color(rng, kWhite, 5));
      const double rim = 0.07;
      p.box(-hx, -hy, -hz, hx, hy, -hz + 0.08, m);
      p.box(-hx, -hy, -hz + 0.08, hx, -hy + rim, hz, m);
      p.box(-hx, hy - rim, -hz + 0.08, hx, hy, hz, m);
      p.box(-hx, -hy + rim, -hz + 0.08, -hx + rim, hy - rim, hz, m);
      p.box(hx - rim, -hy + rim, -hz + 0.08, hx, hy - rim, hz, m);
      break;
    }
    case kSink: {
      const Material base = material(l, pick_color(rng, rng.chance(0.5) ? kWhite : kWood, 8));
      p.box(-hx, -hy, -hz, hx, hy, hz - 0.06, base);
      p.box(-hx, -hy, hz - 0.06, hx, hy, hz, material(l, pick_color(rng, kWhite, 5)));
      break;
    }
    case kAppliances: {
      p.box(-hx, -hy, -hz, hx, hy, hz, material(l, pick_color(rng, kMetal, 6)));
      break;
    }
    case kCounter: {
      p.box(-hx, -hy, -hz, hx, hy, hz - 0.04, material(l, pick_color(rng, kWood), grain, 0.08f));
      p.box(-hx, -hy, hz - 0.04, hx, hy, hz,
            material(l, pick_color(rng, {{90, 90, 95}, {200, 195, 185}}), Texture::kNoise, 0.03f));
      break;
    }
    default: {
      const bool painted = rng.chance(0.3);
      p.box(-hx, -hy, -hz, hx, hy, hz,
            material(l, pick_color(rng, painted ? kWhite : kWood), painted ? Texture::kPlain : grain, 0.08f));
      break;
    }
  }
}

// Places one room's furniture: each candidate is checked against the room's inner walls, the other furniture,
// the keep-out zones in front of doors, and a grid walk that keeps every door reachable from every other.
class Furnisher {
 public:
  Furnisher(World& world, Rng& rng, const Rect& inner, double floor_z, std::int32_t room_id, double clearance_m,
            const std::vector<DoorPlan>& doors, const Rect& room_rect)
      : world_(world), rng_(rng), inner_(inner), floor_z_(floor_z), room_id_(room_id), clearance_m_(clearance_m) {
    for (const DoorPlan& d : doors) {
      // Which side of the door line the room is on.
      const double sign =
          d.axis == 1 ? (room_rect.y0 >= d.c - 1e-6 ? 1.0 : -1.0) : (room_rect.x0 >= d.c - 1e-6 ? 1.0 : -1.0);
      const double lo = d.span.lo - 0.2, hi = d.span.hi + 0.2;
      const double mid = 0.5 * (d.span.lo + d.span.hi);
      const double seed_depth = std::max(0.35, clearance_m_ + 0.15);
      for (int tight = 0; tight < 2; ++tight) {
        const double reach = tight ? kTightKeepOutM : kKeepOutM;
        const double n0 = std::min(d.c, d.c + sign * reach), n1 = std::max(d.c, d.c + sign * reach);
        keep_out_[tight].push_back(d.axis == 1 ? axis_box(lo, n0, floor_z, hi, n1, floor_z + 2.0)
                                               : axis_box(n0, lo, floor_z, n1, hi, floor_z + 2.0));
      }
      seeds_.push_back(d.axis == 1 ? Eigen::Vector2d(mid, d.c + sign * seed_depth)
                                   : Eigen::Vector2d(d.c + sign * seed_depth, mid));
    }
    nx_ = std::max(1, static_cast<int>(std::floor(inner_.width() / kCellM)));
    ny_ = std::max(1, static_cast<int>(std::floor(inner_.height() / kCellM)));
    blocked_.assign(static_cast<std::size_t>(nx_ * ny_), 0);
    for (int y = 0; y < ny_; ++y)
      for (int x = 0; x < nx_; ++x) {
        const Eigen::Vector2d c = cell_center(x, y);
        if (!inner_.contains(c, clearance_m_)) blocked_[static_cast<std::size_t>(y * nx_ + x)] = 1;
      }
  }

  void furnish(const std::vector<Item>& items) {
    std::vector<int> placed(items.size(), -1);  // object id per item
    for (std::size_t i = 0; i < items.size(); ++i) {
      const Item& item = items[i];
      int parent = -1;
      if (item.parent >= 0) {
        parent = placed[static_cast<std::size_t>(item.parent)];
        if (parent < 0) continue;
      }
      const int attempts = item.required ? 160 : 40;
      for (int a = 0; a < attempts; ++a) {
        // Required items shrink a little, and may come closer to doors, after repeated failures rather than go
        // missing; the doorway itself and the path between doors stay clear.
        const double shrink = item.required && a >= 80 ? 0.85 : 1.0;
        const int tight = item.required && a >= 40 ? 1 : 0;
        Eigen::Vector3d size = item.size_m;
        size.x() *= shrink;
        size.y() *= item.label == semantics::kBed ? 1.0 : shrink;
        BoxShape box;
        if (!propose(item, size, parent, a >= 20, a == 0, &box)) continue;
        // A parent is only accepted when its required front child (the chair at a desk) fits too.
        std::vector<BoxShape> group{box};
        for (std::size_t j = i + 1; j < items.size(); ++j)
          if (items[j].parent == static_cast<int>(i) && items[j].mode == Mode::kFront && items[j].required)
            group.push_back(front_of(box, items[j], items[j].size_m, 0.0, 0.0));
        if (!accept(group, parent, item.mode == Mode::kOnTop, tight)) continue;
        Object o;
        o.id = static_cast<std::int32_t>(world_.objects.size());
        o.label = item.label;
        o.box = box;
        o.room_id = room_id_;
        world_.objects.push_back(o);
        if (item.mode != Mode::kOnTop) stamp(box, blocked_);
        placed[i] = o.id;
        Rng look = rng_.fork(static_cast<std::uint64_t>(o.id));
        render_object(world_, world_.objects.back(), look);
        break;
      }
    }
  }

 private:
  static constexpr double kCellM = 0.1;
  static constexpr double kKeepOutM = 1.0;
  static constexpr double kTightKeepOutM = 0.6;

  Eigen::Vector2d cell_center(int x, int y) const {
    return {inner_.x0 + (x + 0.5) * kCellM, inner_.y0 + (y + 0.5) * kCellM};
  }

  static double yaw_of(const BoxShape& b) {
    const Eigen::Matrix3d R = b.world_R_box.toRotationMatrix();
    return std::atan2(R(1, 0), R(0, 0));
  }

  // relax: a corner item may stand anywhere along a wall. nominal: a front item stands centred and square.
  bool propose(const Item& item, const Eigen::Vector3d& size, int parent, bool relax, bool nominal, BoxShape* out) {
    const double w = size.x(), d = size.y();
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    double yaw = 0.0, base_z = floor_z_;
    switch (item.mode) {
      case Mode::kWall:
      case Mode::kCorner: {
        const int side = rng_.uniform_int(0, 3);  // 0 south wall, 1 east, 2 north, 3 west
        const double lo = side % 2 == 0 ? inner_.x0 : inner_.y0, hi = side % 2 == 0 ? inner_.x1 : inner_.y1;
        if (hi - lo < w + 0.02) return false;
        double u;
        if (item.mode == Mode::kCorner && !relax)
          u = rng_.chance(0.5) ? lo + 0.5 * w + 0.01 : hi - 0.5 * w - 0.01;
        else
          u = rng_.uniform(lo + 0.5 * w + 0.01, hi - 0.5 * w - 0.01);
        const double off = 0.5 * d + 0.01;
        switch (side) {
          case 0:
            c = {u, inner_.y0 + off};
            yaw = 0.0;
            break;
          case 1:
            c = {inner_.x1 - off, u};
            yaw = 0.5 * kPi;
            break;
          case 2:
            c = {u, inner_.y1 - off};
            yaw = kPi;
            break;
          default:
            c = {inner_.x0 + off, u};
            yaw = -0.5 * kPi;
            break;
        }
        break;
      }
      case Mode::kCenter: {
        const bool along_long = rng_.chance(0.75) == (inner_.width() >= inner_.height());
        yaw = along_long ? 0.0 : 0.5 * kPi;
        const double ex = along_long ? w : d, ey = along_long ? d : w;
        const double sx = std::max(0.0, 0.5 * (inner_.width() - ex) - 0.6),
                     sy = std::max(0.0, 0.5 * (inner_.height() - ey) - 0.6);
        c = {0.5 * (inner_.x0 + inner_.x1) + rng_.uniform(-0.5, 0.5) * sx,
             0.5 * (inner_.y0 + inner_.y1) + rng_.uniform(-0.5, 0.5) * sy};
        break;
      }
      case Mode::kFront: {
        const BoxShape& p = world_.objects[static_cast<std::size_t>(parent)].box;
        const double along = nominal ? 0.0 : rng_.uniform(-0.05, 0.05) * std::max(0.0, p.half_extents_m.x() - 0.5 * w);
        const double jitter = nominal || item.label != semantics::kChair ? 0.0 : rng_.uniform(-0.15, 0.15);
        *out = front_of(p, item, size, along, jitter);
        return true;
      }
      case Mode::kAround:
      case Mode::kOnTop: {
        const Object& p = world_.objects[static_cast<std::size_t>(parent)];
        const double pyaw = yaw_of(p.box);
        const Eigen::Vector3d ph = p.box.half_extents_m;
        Eigen::Vector2d local;
        double rel = 0.0;
        if (item.mode == Mode::kOnTop) {
          if (w > 2.0 * ph.x() || d > 2.0 * ph.y()) return false;
          local = {rng_.uniform(-1.0, 1.0) * (ph.x() - 0.5 * w), -ph.y() + 0.5 * d + 0.03};
          base_z = p.box.center_m.z() + ph.z();
        } else {
          const int side = rng_.uniform_int(0, 3);  // 0 +y, 1 -y, 2 +x, 3 -x
          const double gap = item.gap_m;
          const double jit = 0.8;
          switch (side) {
            case 0:
              local = {rng_.uniform(-jit, jit) * std::max(0.0, ph.x() - 0.5 * w), ph.y() + gap + 0.5 * d};
              rel = kPi;
              break;
            case 1:
              local = {rng_.uniform(-jit, jit) * std::max(0.0, ph.x() - 0.5 * w), -ph.y() - gap - 0.5 * d};
              rel = 0.0;
              break;
            case 2:
              local = {ph.x() + gap + 0.5 * d, rng_.uniform(-jit, jit) * std::max(0.0, ph.y() - 0.5 * w)};
              rel = 0.5 * kPi;
              break;
            default:
              local = {-ph.x() - gap - 0.5 * d, rng_.uniform(-jit, jit) * std::max(0.0, ph.y() - 0.5 * w)};
              rel = -0.5 * kPi;
              break;
          }
          if (item.label == semantics::kChair) rel += rng_.uniform(-0.15, 0.15);
        }
        c = p.box.center_m.head<2>() + rotate_yaw(pyaw, local);
        yaw = pyaw + rel;
        break;
      }
    }
    *out = yaw_box(Eigen::Vector3d(c.x(), c.y(), base_z + 0.5 * size.z()), size, yaw);
    return true;
  }

  // group[0] is the candidate; the rest must fit beside it (see furnish()).
  bool accept(const std::vector<BoxShape>& group, int parent, bool on_top, int tight) {
    for (std::size_t g = 0; g < group.size(); ++g) {
      const BoxShape& box = group[g];
      for (const Eigen::Vector2d& v : box_footprint(box))
        if (!inner_.contains(v, -1e-9)) return false;
      for (const Object& o : world_.objects) {
        if (o.room_id != room_id_ || o.id == parent) continue;
        if (boxes_overlap(box, o.box, 0.03)) return false;
      }
      for (std::size_t h = 0; h < g; ++h)
        if (boxes_overlap(box, group[h], 0.03)) return false;
      if (on_top) continue;
      for (const BoxShape& k : keep_out_[tight])
        if (boxes_overlap(box, k)) return false;
    }
    if (on_top || seeds_.size() < 2) return true;
    std::vector<std::uint8_t> grid = blocked_;
    for (const BoxShape& box : group) stamp(box, grid);
    return doors_connected(grid);
  }

  // The box of an item standing gap_m in front of (+y of) a parent, facing it; along_m shifts it sideways.
  static BoxShape front_of(const BoxShape& parent, const Item& item, const Eigen::Vector3d& size, double along_m,
                           double yaw_jitter_rad) {
    const double pyaw = yaw_of(parent);
    const Eigen::Vector2d local(along_m, parent.half_extents_m.y() + item.gap_m + 0.5 * size.y());
    const Eigen::Vector2d c = parent.center_m.head<2>() + rotate_yaw(pyaw, local);
    const double floor_z = parent.center_m.z() - parent.half_extents_m.z();
    return yaw_box(Eigen::Vector3d(c.x(), c.y(), floor_z + 0.5 * size.z()), size, pyaw + kPi + yaw_jitter_rad);
  }

  // Marks the cells the box (grown by the robot clearance) covers.
  void stamp(const BoxShape& box, std::vector<std::uint8_t>& grid) const {
    BoxShape grown = box;
    grown.half_extents_m.head<2>().array() += clearance_m_;
    const std::vector<Eigen::Vector2d> fp = box_footprint(grown);
    Polygon2 poly(fp.begin(), fp.end());
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (const Eigen::Vector2d& v : fp) {
      x0 = std::min(x0, v.x());
      y0 = std::min(y0, v.y());
      x1 = std::max(x1, v.x());
      y1 = std::max(y1, v.y());
    }
    const int cx0 = std::max(0, static_cast<int>(std::floor((x0 - inner_.x0) / kCellM)));
    const int cy0 = std::max(0, static_cast<int>(std::floor((y0 - inner_.y0) / kCellM)));
    const int cx1 = std::min(nx_ - 1, static_cast<int>(std::floor((x1 - inner_.x0) / kCellM)));
    const int cy1 = std::min(ny_ - 1, static_cast<int>(std::floor((y1 - inner_.y0) / kCellM)));
    for (int y = cy0; y <= cy1; ++y)
      for (int x = cx0; x <= cx1; ++x)
        if (point_in_polygon(poly, cell_center(x, y))) grid[static_cast<std::size_t>(y * nx_ + x)] = 1;
  }

  bool doors_connected(const std::vector<std::uint8_t>& grid) const {
    auto cell = [&](const Eigen::Vector2d& p) {
      const int x = std::clamp(static_cast<int>(std::floor((p.x() - inner_.x0) / kCellM)), 0, nx_ - 1);
      const int y = std::clamp(static_cast<int>(std::floor((p.y() - inner_.y0) / kCellM)), 0, ny_ - 1);
      return y * nx_ + x;
    };
    std::vector<std::uint8_t> seen(grid.size(), 0);
    std::deque<int> queue;
    const int start = cell(seeds_[0]);
    if (grid[static_cast<std::size_t>(start)]) return false;
    queue.push_back(start);
    seen[static_cast<std::size_t>(start)] = 1;
    while (!queue.empty()) {
      const int i = queue.front();
      queue.pop_front();
      const int x = i % nx_, y = i / nx_;
      const int nb[4][2] = {{x + 1, y}, {x - 1, y}, {x, y + 1}, {x, y - 1}};
      for (const auto& n : nb) {
        if (n[0] < 0 || n[1] < 0 || n[0] >= nx_ || n[1] >= ny_) continue;
        const std::size_t j = static_cast<std::size_t>(n[1] * nx_ + n[0]);
        if (seen[j] || grid[j]) continue;
        seen[j] = 1;
        queue.push_back(static_cast<int>(j));
      }
    }
    for (const Eigen::Vector2d& s : seeds_)
      if (!seen[static_cast<std::size_t>(cell(s))]) return false;
    return true;
  }

  World& world_;
  Rng& rng_;
  Rect inner_;
  double floor_z_;
  std::int32_t room_id_;
  double clearance_m_;
  std::array<std::vector<BoxShape>, 2> keep_out_;  // normal and tight keep-out zones in front of doors
  std::vector<Eigen::Vector2d> seeds_;
  int nx_ = 1, ny_ = 1;
  std::vector<std::uint8_t> blocked_;
};

}  // namespace

void BuildingConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "BuildingConfig: name=%s seed=%llu num_rooms=%d room_size_m=[%.2f, %.2f] ceiling_height_m=%.2f "
               "wall_thickness_m=%.3f hallway_width_m=[%.2f, %.2f] max_hallway_length_m=%.1f door_width_m=[%.2f, "
               "%.2f] door_height_m=%.2f two_floors=%d slab_thickness_m=%.2f annex_probability=%.2f "
               "extra_door_probability=%.2f furnish=%d robot_clearance_m=%.2f\n",
               name.c_str(), static_cast<unsigned long long>(seed), num_rooms, room_size_min_m, room_size_max_m,
               ceiling_height_m, wall_thickness_m, hallway_width_min_m, hallway_width_max_m, max_hallway_length_m,
               door_width_min_m, door_width_max_m, door_height_m, two_floors ? 1 : 0, slab_thickness_m,
               annex_probability, extra_door_probability, furnish ? 1 : 0, robot_clearance_m);
}

std::string BuildingConfig::validate() const {
  const int min_rooms = two_floors ? 8 : 3;
  if (num_rooms < min_rooms)
    return "num_rooms " + std::to_string(num_rooms) + " is below the minimum of " + std::to_string(min_rooms) +
           (two_floors ? " for two floors" : "");
  if (room_size_min_m < 2.5) return "room_size_min_m must be at least 2.5";
  if (room_size_max_m < room_size_min_m) return "room_size_max_m is below room_size_min_m";
  if (door_width_min_m < 0.6 || door_width_max_m < door_width_min_m)
    return "door widths must satisfy 0.6 <= min <= max";
  if (ceiling_height_m < 2.2) return "ceiling_height_m must be at least 2.2";
  if (door_height_m > ceiling_height_m) return "door_height_m exceeds ceiling_height_m";
  if (hallway_width_min_m < door_width_min_m + 0.4 + wall_thickness_m)
    return "hallway_width_min_m too small for a door across the corridor";
  if (hallway_width_max_m < hallway_width_min_m) return "hallway_width_max_m is below hallway_width_min_m";
  if (wall_thickness_m < 0.02 || wall_thickness_m > 0.4) return "wall_thickness_m must lie in [0.02, 0.4]";
  return {};
}

World generate_building(const BuildingConfig& config_in) {
  using namespace semantics;
  const BuildingConfig c = clamped(config_in);
  Rng root(c.seed);
  Rng layout_rng = root.fork(1), door_rng = root.fork(2), look_rng = root.fork(3), furniture_rng = root.fork(4);
  const double t = c.wall_thickness_m;
  const int floors = c.two_floors ? 2 : 1;
  const double storey_m = c.ceiling_height_m + c.slab_thickness_m;

  // Shell shared by all floors: corridor width, strip depths, stairwell.
  Shell shell;
  shell.hallway_width_m = layout_rng.uniform(c.hallway_width_min_m, c.hallway_width_max_m);
  shell.north_depth_m = layout_rng.uniform(c.room_size_min_m, c.room_size_max_m);
  shell.south_depth_m = layout_rng.uniform(c.room_size_min_m, c.room_size_max_m);
  const int risers = static_cast<int>(std::ceil(storey_m / kStairMaxRiseM - 1e-9));
  const double rise_m = storey_m / risers, run_m = (risers - 1) * kStairTreadM;
  if (c.two_floors) {
    shell.stairwell_width_m = kStairwellWidthM;
    shell.north_depth_m = std::max(shell.north_depth_m, t + 2.0 * kStairLandingM + run_m);
  }
  const double wc = shell.hallway_width_m;
  // The stairwell's door keeps clear of the flight (and the railing above it).
  const double stair_door_clip_m = 0.5 * t + kStairWidthM + kRailingThicknessM;

  World world;
  world.name = c.name + "_seed" + std::to_string(c.seed);
  std::vector<RoomPlan> rooms;
  std::vector<DoorPlan> doors;
  std::vector<int> stairwell_of_floor(static_cast<std::size_t>(floors), -1);
  double length_m = -1.0;

  for (int f = 0; f < floors; ++f) {
    const int target = f == 0 ? (c.num_rooms + floors - 1) / floors : c.num_rooms / floors;
    Rng floor_rng = layout_rng.fork(static_cast<std::uint64_t>(f) + 10);
    const FloorLayout layout = plan_floor(floor_rng, c, shell, f, target, length_m);
    length_m = layout.length_m;
    const double L = layout.length_m;

    // Where the corridor is cut into hallway rooms: near equal lengths, but never so that a room along the
    // corridor is left without a stretch of hallway wall wide enough for its door.
    std::vector<Interval> frontage;
    if (c.two_floors) frontage.push_back({stair_door_clip_m, shell.stairwell_width_m});
    {
      double cursor_n = shell.stairwell_width_m, cursor_s = 0.0;
      for (const Segment& seg : layout.segments) {
        double& cursor = seg.side == 1 ? cursor_n : cursor_s;
        frontage.push_back({cursor, cursor + seg.width});
        cursor += seg.width;
      }
    }
    const double door_need = c.door_width_min_m + 2.0 * (0.15 + 0.5 * t) + 0.01;
    std::vector<double> cuts{0.0};
    for (int h = 1; h < layout.hallways; ++h) {
      const double ideal = L * h / layout.hallways;
      double best = ideal;
      for (int k = 0; k < 2000; ++k) {
        const double x = ideal + (k % 2 ? 1.0 : -1.0) * 0.01 * ((k + 1) / 2);
        bool ok = x > cuts.back() + 2.0 && x < L - 2.0;
        for (const Interval& fr : frontage)
          if (x > fr.lo && x < fr.hi && std::max(x - fr.lo, fr.hi - x) < door_need) ok = false;
        if (ok) {
          best = x;
          break;
        }
      }
      cuts.push_back(best);
    }
    cuts.push_back(L);
    std::vector<int> hallway_ids;
    for (int h = 0; h < layout.hallways; ++h) {
      hallway_ids.push_back(static_cast<int>(rooms.size()));
      rooms.push_back(
          {kHallway, {cuts[static_cast<std::size_t>(h)], 0.0, cuts[static_cast<std::size_t>(h) + 1], wc}, f});
    }
    if (c.two_floors) {
      stairwell_of_floor[static_cast<std::size_t>(f)] = static_cast<int>(rooms.size());
      rooms.push_back({kStairwell, {0.0, wc, shell.stairwell_width_m, wc + shell.north_depth_m}, f});
    }
    // Rooms of the strips; remember (front, back, side) for the door pass.
    struct Placed {
      int front, back, side;
    };
    std::vector<Placed> placed;
    double cursor_n = shell.stairwell_width_m, cursor_s = 0.0;
    for (const Segment& seg : layout.segments) {
      double& cursor = seg.side == 1 ? cursor_n : cursor_s;
      const double x0 = cursor, x1 = cursor + seg.width;
      cursor = x1;
      const double depth = seg.side == 1 ? shell.north_depth_m : shell.south_depth_m;
      const double front_depth = seg.back != kRoomUnknown ? depth - seg.back_depth : depth;
      Placed p{static_cast<int>(rooms.size()), -1, seg.side};
      if (seg.side == 1)
        rooms.push_back({seg.front, {x0, wc, x1, wc + front_depth}, f});
      else
        rooms.push_back({seg.front, {x0, -front_depth, x1, 0.0}, f});
      if (seg.back != kRoomUnknown) {
        p.back = static_cast<int>(rooms.size());
        if (seg.side == 1)
          rooms.push_back({seg.back, {x0, wc + front_depth, x1, wc + depth}, f});
        else
          rooms.push_back({seg.back, {x0, -depth, x1, -front_depth}, f});
      }
      placed.push_back(p);
    }

    // Doors: the spanning set first (hallway chain, every front room to the corridor, back rooms to their front).
    auto add_door = [&](int a, int b, double lo_clip) {
      int axis = 1;
      double line = 0.0;
      Interval span;
      if (!shared_edge(rooms[static_cast<std::size_t>(a)].rect, rooms[static_cast<std::size_t>(b)].rect, &axis, &line,
                       &span))
        return false;
      span.lo = std::max(span.lo, lo_clip);
      const double margin = 0.15 + 0.5 * t;
      const Interval usable{span.lo + margin, span.hi - margin};
      double w = door_rng.uniform(c.door_width_min_m, c.door_width_max_m);
      w = std::min(w, usable.length());
      if (w < c.door_width_min_m - 1e-9) return false;
      // Doors mostly sit near a corner, as in real buildings; that leaves long walls for furniture.
      const double u = door_rng.uniform();
      const double lo = u < 0.35 ? usable.lo : u < 0.7 ? usable.hi - w : door_rng.uniform(usable.lo, usable.hi - w);
      doors.push_back({axis, line, {lo, lo + w}, a, b, f, true});
      return true;
    };
    for (std::size_t h = 0; h + 1 < hallway_ids.size(); ++h) add_door(hallway_ids[h], hallway_ids[h + 1], -1e9);
    auto door_to_corridor = [&](int room, double lo_clip) {
      // The hallway piece sharing the longest stretch of wall with the room.
      int best = -1;
      double best_len = 0.0;
      for (int h : hallway_ids) {
        int axis;
        double line;
        Interval span;
        if (!shared_edge(rooms[static_cast<std::size_t>(room)].rect, rooms[static_cast<std::size_t>(h)].rect, &axis,
                         &line, &span))
          continue;
        const double len = std::min(span.hi, 1e9) - std::max(span.lo, lo_clip);
        if (len > best_len) {
          best_len = len;
          best = h;
        }
      }
      if (best >= 0) add_door(room, best, lo_clip);
    };
    if (c.two_floors) door_to_corridor(stairwell_of_floor[static_cast<std::size_t>(f)], stair_door_clip_m);
    for (const Placed& p : placed) {
      door_to_corridor(p.front, -1e9);
      if (p.back >= 0) add_door(p.back, p.front, -1e9);
    }
    // Extra doors between neighbouring front rooms make loops (not into bathrooms, closets or bedrooms, which
    // also keeps the walls of those small rooms free for their furniture).
    for (std::size_t i = 0; i + 1 < placed.size(); ++i) {
      const Placed& a = placed[i];
      const Placed& b = placed[i + 1];
      if (a.side != b.side) continue;
      const RoomLabel la = rooms[static_cast<std::size_t>(a.front)].label,
                      lb = rooms[static_cast<std::size_t>(b.front)].label;
      auto private_room = [](RoomLabel l) { return l == kBathroom || l == kCloset || l == kBedroom; };
      if (private_room(la) || private_room(lb)) continue;
      if (door_rng.chance(c.extra_door_probability)) add_door(a.front, b.front, -1e9);
    }
  }

  // Stair top: an opening between the two stairwells.
  const double stair_x0 = 0.5 * t, stair_x1 = 0.5 * t + kStairWidthM;
  const double stair_y0 = wc + 0.5 * t + kStairLandingM, stair_y1 = stair_y0 + run_m;
  if (c.two_floors)
    doors.push_back({1, stair_y1, {stair_x0, stair_x1}, stairwell_of_floor[0], stairwell_of_floor[1], 1, false});

  // Rooms into the world.
  for (std::size_t i = 0; i < rooms.size(); ++i) {
    Room r;
    r.id = static_cast<std::int32_t>(i);
    r.label = rooms[i].label;
    r.footprint_m = {rooms[i].rect.polygon()};
    r.floor_z_m = rooms[i].floor * storey_m;
    r.height_m = c.ceiling_height_m;
    r.floor_index = rooms[i].floor;
    world.rooms.push_back(r);
  }
  for (const DoorPlan& d : doors) {
    Door door;
    door.a_m = d.axis == 1 ? Eigen::Vector2d(d.span.lo, d.c) : Eigen::Vector2d(d.c, d.span.lo);
    door.b_m = d.axis == 1 ? Eigen::Vector2d(d.span.hi, d.c) : Eigen::Vector2d(d.c, d.span.hi);
    door.floor_z_m = d.floor * storey_m;
    door.height_m = d.in_wall ? c.door_height_m : c.ceiling_height_m;
    door.room_a = d.room_a;
    door.room_b = d.room_b;
    world.doors.push_back(door);
  }

  // Structure: per room floor, ceiling and the inner half of each wall (door gaps with lintels).
  const Rect opening{stair_x0, stair_y0, stair_x1, stair_y1};
  for (std::size_t i = 0; i < rooms.size(); ++i) {
    const RoomPlan& rp = rooms[i];
    const Rect& q = rp.rect;
    const double fz = rp.floor * storey_m;
    const std::int32_t rid = static_cast<std::int32_t>(i);
    Rng look_room = look_rng.fork(i);
    const RoomLook look = room_look(look_room, rp.label);
    const double half_slab = 0.5 * c.slab_thickness_m;
    const bool is_stairwell = c.two_floors && rp.label == kStairwell;
    const std::vector<Rect> floor_parts =
        is_stairwell && rp.floor == 1 ? subtract_rect(q, opening) : std::vector<Rect>{q};
    const std::vector<Rect> ceil_parts =
        is_stairwell && rp.floor == 0 ? subtract_rect(q, opening) : std::vector<Rect>{q};
    for (const Rect& p : floor_parts)
      world.add_box(axis_box(p.x0, p.y0, fz - half_slab, p.x1, p.y1, fz), look.floor, -1, rid);
    for (const Rect& p : ceil_parts)
      world.add_box(axis_box(p.x0, p.y0, fz + c.ceiling_height_m, p.x1, p.y1, fz + c.ceiling_height_m + half_slab),
                    look.ceiling, -1, rid);
    // Edges counter-clockwise, so "left" of each edge points into the room.
    const Eigen::Vector2d corners[4] = {{q.x0, q.y0}, {q.x1, q.y0}, {q.x1, q.y1}, {q.x0, q.y1}};
    for (int e = 0; e < 4; ++e) {
      const Eigen::Vector2d& from = corners[e];
      const Eigen::Vector2d& to = corners[(e + 1) % 4];
      const int axis = e % 2 == 0 ? 1 : 0;  // edges 0 and 2 lie on y = const
      const double line = axis == 1 ? from.y() : from.x();
      std::vector<Interval> gaps;
      for (const DoorPlan& d : doors) {
        if (!d.in_wall || d.floor != rp.floor || d.axis != axis || std::abs(d.c - line) > 1e-6) continue;
        if (d.room_a != rid && d.room_b != rid) continue;
        // Distance along the edge from `from`.
        const double s0 = axis == 1 ? std::abs(d.span.lo - from.x()) : std::abs(d.span.lo - from.y());
        const double s1 = axis == 1 ? std::abs(d.span.hi - from.x()) : std::abs(d.span.hi - from.y());
        gaps.push_back({std::min(s0, s1), std::max(s0, s1)});
      }
      add_wall_with_gaps(world, from, to, 0.5 * t, 0.25 * t, fz, fz + c.ceiling_height_m, gaps, fz + c.door_height_m,
                         look.wall, rid);
    }
  }
  // Outer half of the exterior walls, one box per side for the whole height of the building.
  {
    double y_min = -shell.south_depth_m, y_max = wc + shell.north_depth_m;
    const double z0 = -0.5 * c.slab_thickness_m,
                 z1 = (floors - 1) * storey_m + c.ceiling_height_m + 0.5 * c.slab_thickness_m;
    const Material outer = material(kWall, jitter(look_rng, {200, 190, 175}, 10), Texture::kNoise, 0.3f);
    const double h = 0.5 * t;
    world.add_box(axis_box(-h, y_min - h, z0, length_m + h, y_min, z1), outer);
    world.add_box(axis_box(-h, y_max, z0, length_m + h, y_max + h, z1), outer);
    world.add_box(axis_box(-h, y_min, z0, 0.0, y_max, z1), outer);
    world.add_box(axis_box(length_m, y_min, z0, length_m + h, y_max, z1), outer);
  }
  // Stairs and the railing around the opening upstairs.
  if (c.two_floors) {
    const std::int32_t s0 = stairwell_of_floor[0], s1 = stairwell_of_floor[1];
    const Material concrete = material(kStairs, jitter(look_rng, {170, 165, 160}, 10), Texture::kNoise, 0.2f);
    for (int i = 0; i + 1 < risers; ++i)
      world.add_box(axis_box(stair_x0, stair_y0 + i * kStairTreadM, 0.0, stair_x1, stair_y0 + (i + 1) * kStairTreadM,
                             (i + 1) * rise_m),
                    concrete, -1, s0);
    const Material rail = material(kRailing, jitter(look_rng, {90, 90, 95}, 10));
    const double z = storey_m;
    world.add_box(axis_box(stair_x1, stair_y0 - kRailingThicknessM, z, stair_x1 + kRailingThicknessM, stair_y1,
                           z + kRailingHeightM),
                  rail, -1, s1);
    world.add_box(axis_box(stair_x0, stair_y0 - kRailingThicknessM, z, stair_x1, stair_y0, z + kRailingHeightM), rail,
                  -1, s1);
  }

  // Furniture, room by room.
  if (c.furnish) {
    for (std::size_t i = 0; i < rooms.size(); ++i) {
      const RoomPlan& rp = rooms[i];
      if (rp.label == kStairwell) continue;
      Rng room_rng = furniture_rng.fork(i);
      std::vector<DoorPlan> room_doors;
      for (const DoorPlan& d : doors)
        if (d.in_wall && (d.room_a == static_cast<int>(i) || d.room_b == static_cast<int>(i))) room_doors.push_back(d);
      const Rect inner{rp.rect.x0 + 0.5 * t, rp.rect.y0 + 0.5 * t, rp.rect.x1 - 0.5 * t, rp.rect.y1 - 0.5 * t};
      Furnisher furnisher(world, room_rng, inner, rp.floor * storey_m, static_cast<std::int32_t>(i),
                          c.robot_clearance_m, room_doors, rp.rect);
      furnisher.furnish(furniture_for(room_rng, rp.label));
    }
  }
  return world;
}

}  // namespace qsg::world
