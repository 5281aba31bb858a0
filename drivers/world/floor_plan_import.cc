// Floor-plan import: occupancy pixels to merged wall boxes, ground-truth regions to room polygons, separator lines
// over free space to doors.
#include "drivers/world/floor_plan_import.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "drivers/world/world_geometry.h"
#include "drivers/world/world_query.h"

namespace qsg::world {
namespace {

bool to_grey(const cv::Mat& in, cv::Mat* out, std::string* error) {
  if (in.empty()) {
    *error = "image is empty";
    return false;
  }
  if (in.depth() != CV_8U) {
    *error = "image must be 8-bit";
    return false;
  }
  switch (in.channels()) {
    case 1: *out = in; return true;
    case 3: cv::cvtColor(in, *out, cv::COLOR_BGR2GRAY); return true;
    case 4: cv::cvtColor(in, *out, cv::COLOR_BGRA2GRAY); return true;
    default: *error = "image must have 1, 3 or 4 channels, not " + std::to_string(in.channels()); return false;
  }
}

// Empty when a w x h image is within the config's limits, else why not.
std::string image_size_error(std::int64_t w, std::int64_t h, const FloorPlanConfig& config) {
  if (w <= config.max_image_side_px && h <= config.max_image_side_px && w * h <= config.max_image_pixels) return {};
  return "image of " + std::to_string(w) + " x " + std::to_string(h) + " px exceeds the floor-plan limit (" +
         "max_image_side_px " + std::to_string(config.max_image_side_px) + ", max_image_pixels " +
         std::to_string(config.max_image_pixels) + ")";
}

std::string stem_of(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const std::size_t dot = name.find_last_of('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

// Joins a hole (opposite orientation) into an outer polygon through a two-way slit between their nearest vertices:
// outer[0..i], hole[j..], hole[..j], outer[i..]. The slit's two edges coincide, so a ray crosses both or neither.
void cut_hole(Polygon2* outer, const Polygon2& hole) {
  std::size_t bi = 0, bj = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < outer->size(); ++i)
    for (std::size_t j = 0; j < hole.size(); ++j) {
      const double d = ((*outer)[i] - hole[j]).squaredNorm();
      if (d < best) {
        best = d;
        bi = i;
        bj = j;
      }
    }
  Polygon2 out(outer->begin(), outer->begin() + static_cast<std::ptrdiff_t>(bi) + 1);
  for (std::size_t k = 0; k <= hole.size(); ++k) out.push_back(hole[(bj + k) % hole.size()]);
  out.insert(out.end(), outer->begin() + static_cast<std::ptrdiff_t>(bi), outer->end());
  *outer = std::move(out);
}

}  // namespace

void FloorPlanConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "FloorPlanConfig: resolution_m_per_px=%.4f free_threshold=%d gt_room_threshold=%d min_room_area_px=%d "
               "wall_height_m=%.2f door_height_m=%.2f contour_epsilon_px=%.2f crop_margin_px=%d "
               "add_floor_and_ceiling=%d min_door_width_m=%.2f separator_search_px=%d furniture_height_m=%.2f "
               "min_hole_area_px=%.0f max_image_side_px=%d max_image_pixels=%lld\n",
               resolution_m_per_px, free_threshold, gt_room_threshold, min_room_area_px, wall_height_m, door_height_m,
               contour_epsilon_px, crop_margin_px, add_floor_and_ceiling ? 1 : 0, min_door_width_m,
               separator_search_px, furniture_height_m, min_hole_area_px, max_image_side_px,
               static_cast<long long>(max_image_pixels));
}

namespace {

std::uint32_t big_endian(const unsigned char* p, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

// PNM: "P1".."P6", then width and height as decimal text, with whitespace and # comments between. Read exactly
// as the decoder (OpenCV's PxM reader) reads it, so the size checked here is the size it will allocate: a comment
// ends at '\n' or '\r', whitespace is any of " \t\n\v\f\r", and the character after a number is consumed.
bool pnm_size(std::FILE* f, int* w, int* h) {
  const auto is_space = [](int c) { return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r'; };
  long values[2] = {0, 0};
  for (long& v : values) {
    int c = std::fgetc(f);
    for (;;) {
      if (c == '#') {
        do c = std::fgetc(f);
        while (c != '\n' && c != '\r' && c != EOF);
        if (c == EOF) return false;
        c = std::fgetc(f);
      } else if (is_space(c)) {
        c = std::fgetc(f);
      } else {
        break;
      }
    }
    if (c < '0' || c > '9') return false;
    for (; c >= '0' && c <= '9'; c = std::fgetc(f)) {
      v = v * 10 + (c - '0');
      if (v > 1000000000L) return false;
    }
  }
  *w = static_cast<int>(values[0]);
  *h = static_cast<int>(values[1]);
  return true;
}

// JPEG: walk the marker segments to the first start-of-frame (SOF0..SOF15 but DHT, JPG and DAC).
bool jpeg_size(std::FILE* f, int* w, int* h) {
  unsigned char m[2];
  for (int segments = 0; segments < 1000; ++segments) {
    if (std::fread(m, 1, 2, f) != 2 || m[0] != 0xFF) return false;
    while (m[1] == 0xFF)  // fill bytes
      if (std::fread(&m[1], 1, 1, f) != 1) return false;
    const unsigned marker = m[1];
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // no length
    unsigned char len[2];
    if (std::fread(len, 1, 2, f) != 2) return false;
    const std::uint32_t length = big_endian(len, 2);
    if (length < 2) return false;
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      unsigned char sof[5];
      if (length < 7 || std::fread(sof, 1, 5, f) != 5) return false;
      *h = static_cast<int>(big_endian(sof + 1, 2));
      *w = static_cast<int>(big_endian(sof + 3, 2));
      return true;
    }
    if (std::fseek(f, static_cast<long>(length) - 2, SEEK_CUR) != 0) return false;
  }
  return false;
}

}  // namespace

bool read_image_size(const std::string& path, int* width_px, int* height_px, std::string* error) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    *error = path + ": cannot read (" + std::strerror(errno) + ")";
    return false;
  }
  unsigned char head[26] = {};
  const std::size_t n = std::fread(head, 1, sizeof(head), f);
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  bool ok = false;
  std::int64_t w = 0, h = 0;
  if (n >= 24 && std::equal(kPng, kPng + 8, head) && std::equal(head + 12, head + 16, "IHDR")) {
    w = big_endian(head + 16, 4);
    h = big_endian(head + 20, 4);
    ok = true;
  } else if (n >= 26 && head[0] == 'B' && head[1] == 'M') {
    const auto le32 = [&](int at) {
      return static_cast<std::int32_t>(static_cast<std::uint32_t>(head[at]) | (static_cast<std::uint32_t>(head[at + 1]) << 8) |
                                       (static_cast<std::uint32_t>(head[at + 2]) << 16) |
                                       (static_cast<std::uint32_t>(head[at + 3]) << 24));
    };
    w = le32(18);
    h = le32(22);
    if (h < 0) h = -h;  // top-down rows
    ok = true;
  } else if (n >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF) {
    int jw = 0, jh = 0;
    ok = std::fseek(f, 2, SEEK_SET) == 0 && jpeg_size(f, &jw, &jh);
    w = jw;
    h = jh;
  } else if (n >= 2 && head[0] == 'P' && head[1] >= '1' && head[1] <= '6') {
    int pw = 0, ph = 0;
    ok = std::fseek(f, 2, SEEK_SET) == 0 && pnm_size(f, &pw, &ph);
    w = pw;
    h = ph;
  } else {
    std::fclose(f);
    *error = path + ": not a PNG, JPEG, BMP or PNM image (the formats whose size is checked before decoding)";
    return false;
  }
  std::fclose(f);
  if (!ok || w <= 0 || h <= 0 || w > INT32_MAX || h > INT32_MAX) {
    *error = path + ": unreadable image header";
    return false;
  }
  *width_px = static_cast<int>(w);
  *height_px = static_cast<int>(h);
  return true;
}

std::string floor_plan_gt_path(const std::string& occupancy_path) {
  std::string base = occupancy_path;
  const std::size_t dot = base.find_last_of('.');
  const std::size_t slash = base.find_last_of('/');
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash)) base = base.substr(0, dot);
  const std::string suffix = "_furnitures";
  if (base.size() > suffix.size() && base.compare(base.size() - suffix.size(), suffix.size(), suffix) == 0)
    base.resize(base.size() - suffix.size());
  return base + "_gt_segmentation.png";
}

WorldResult import_floor_plan(const cv::Mat& occupancy_in, const cv::Mat& gt_in, const FloorPlanConfig& config,
                              const std::string& name, FloorPlanStats* stats_out, const cv::Mat& furniture) {
  using namespace semantics;
  WorldResult result;
  FloorPlanStats stats;
  cv::Mat occ;
  if (!(config.max_image_side_px >= 16 && config.max_image_side_px <= 32768 && config.max_image_pixels >= 256 &&
        config.max_image_pixels <= (std::int64_t{1} << 28))) {
    result.error = "max_image_side_px must be in [16, 32768] and max_image_pixels in [256, 2^28]";
    return result;
  }
  if (const std::string bad = image_size_error(occupancy_in.cols, occupancy_in.rows, config); !bad.empty()) {
    result.error = "occupancy " + bad;
    return result;
  }
  if (!to_grey(occupancy_in, &occ, &result.error)) {
    result.error = "occupancy " + result.error;
    return result;
  }
  const double res = config.resolution_m_per_px;
  if (!(res > 0.0)) {
    result.error = "resolution_m_per_px must be positive";
    return result;
  }
  const int rows = occ.rows, cols = occ.cols;
  auto px_x = [&](double col) { return col * res; };
  auto px_y = [&](double row) { return (rows - row) * res; };

  const cv::Mat free_mask = occ >= config.free_threshold;
  std::vector<cv::Point> free_points;
  cv::findNonZero(free_mask, free_points);
  if (free_points.empty()) {
    result.error = "occupancy image has no free pixels (none >= " + std::to_string(config.free_threshold) + ")";
    return result;
  }
  cv::Rect crop = cv::boundingRect(free_points);
  crop.x -= config.crop_margin_px;
  crop.y -= config.crop_margin_px;
  crop.width += 2 * config.crop_margin_px;
  crop.height += 2 * config.crop_margin_px;
  crop &= cv::Rect(0, 0, cols, rows);

  World& world = result.world;
  world.name = name;

  // Greedy rectangle merging: take the longest run of unclaimed occupied pixels, grow it downwards while the next
  // row's span is entirely unclaimed and occupied. Keeps the box count to a few per wall segment. Pixels of the
  // furniture mask (when given, with furniture_height_m > 0) are merged apart and extruded to that height.
  if (!furniture.empty() && (furniture.size() != occ.size() || furniture.type() != CV_8UC1)) {
    result.error = "furniture mask must be 8-bit single-channel and the occupancy image's size";
    return result;
  }
  const bool low_furniture = !furniture.empty() && config.furniture_height_m > 0.0;
  Material wall;
  wall.label = kWall;
  wall.color = {{205, 200, 190}};
  wall.texture = Texture::kNoise;
  wall.texture_scale_m = 0.3f;
  Material furniture_m;
  furniture_m.label = kFurniture;
  furniture_m.color = {{140, 109, 49}};
  furniture_m.texture = Texture::kNoise;
  furniture_m.texture_scale_m = 0.2f;
  cv::Mat claimed = cv::Mat::zeros(rows, cols, CV_8U);
  const double h = config.wall_height_m;
  for (int pass = 0; pass < (low_furniture ? 2 : 1); ++pass) {
    // Pass 0: walls (every occupied pixel unless furniture is low); pass 1: the furniture mask's pixels.
    const auto in_class = [&](int r, int c) {
      if (occ.ptr<std::uint8_t>(r)[c] >= config.free_threshold) return false;
      if (!low_furniture) return true;
      return (furniture.ptr<std::uint8_t>(r)[c] != 0) == (pass == 1);
    };
    const double top = pass == 1 ? config.furniture_height_m : h;
    for (int r = crop.y; r < crop.y + crop.height; ++r) {
      std::uint8_t* crow = claimed.ptr<std::uint8_t>(r);
      for (int c = crop.x; c < crop.x + crop.width; ++c) {
        if (!in_class(r, c) || crow[c]) continue;
        ++stats.occupied_px;
        int w = 1;
        while (c + w < crop.x + crop.width && in_class(r, c + w) && !crow[c + w]) ++w;
        int hgt = 1;
        for (; r + hgt < crop.y + crop.height; ++hgt) {
          const std::uint8_t* c2 = claimed.ptr<std::uint8_t>(r + hgt);
          bool full = true;
          for (int k = c; k < c + w && full; ++k) full = in_class(r + hgt, k) && !c2[k];
          if (!full) break;
        }
        for (int rr = r; rr < r + hgt; ++rr) std::fill_n(claimed.ptr<std::uint8_t>(rr) + c, w, std::uint8_t{1});
        stats.occupied_px += w * hgt - 1;
        world.add_box(axis_box(px_x(c), px_y(r + hgt), 0.0, px_x(c + w), px_y(r), top), pass == 1 ? furniture_m : wall);
        ++(pass == 1 ? stats.furniture_boxes : stats.wall_boxes);
        c += w - 1;
      }
    }
  }
  if (config.add_floor_and_ceiling) {
    Material floor_m, ceiling_m;
    floor_m.label = kFloor;
    floor_m.color = {{150, 140, 125}};
    floor_m.texture = Texture::kChecker;
    floor_m.texture_scale_m = 0.5f;
    ceiling_m.label = kCeiling;
    ceiling_m.color = {{240, 240, 235}};
    const double x0 = px_x(crop.x), x1 = px_x(crop.x + crop.width);
    const double y0 = px_y(crop.y + crop.height), y1 = px_y(crop.y);
    world.add_box(axis_box(x0, y0, -0.1, x1, y1, 0.0), floor_m);
    world.add_box(axis_box(x0, y0, h, x1, y1, h + 0.1), ceiling_m);
  }

  if (!gt_in.empty()) {
    cv::Mat gt;
    if (!to_grey(gt_in, &gt, &result.error)) {
      result.error = "ground truth " + result.error;
      return result;
    }
    if (gt.size() != occ.size()) {
      result.error = "ground truth is " + std::to_string(gt.cols) + "x" + std::to_string(gt.rows) +
                     " but the occupancy image is " + std::to_string(cols) + "x" + std::to_string(rows);
      return result;
    }
    const cv::Mat white = gt > config.gt_room_threshold;
    cv::Mat labels, cc_stats, centroids;
    const int n = cv::connectedComponentsWithStats(white, labels, cc_stats, centroids, 8, CV_32S);
    stats.gt_regions = n - 1;
    std::vector<int> room_of_label(static_cast<std::size_t>(n), -1);
    for (int i = 1; i < n; ++i) {
      if (cc_stats.at<int>(i, cv::CC_STAT_AREA) < config.min_room_area_px) continue;
      const cv::Rect box(cc_stats.at<int>(i, cv::CC_STAT_LEFT), cc_stats.at<int>(i, cv::CC_STAT_TOP),
                         cc_stats.at<int>(i, cv::CC_STAT_WIDTH), cc_stats.at<int>(i, cv::CC_STAT_HEIGHT));
      // One pixel of padding so the contour of a region touching the border is still closed.
      const cv::Rect padded = (box + cv::Size(2, 2)) - cv::Point(1, 1);
      const cv::Rect roi = padded & cv::Rect(0, 0, cols, rows);
      cv::Mat mask = cv::Mat::zeros(padded.size(), CV_8U);
      cv::Mat sub = mask(roi - padded.tl());
      sub.setTo(255, labels(roi) == i);
      std::vector<std::vector<cv::Point>> contours;
      std::vector<cv::Vec4i> hierarchy;  // next, previous, first child, parent
      cv::findContours(mask, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
      std::size_t best = 0;
      double best_area = -1.0;
      for (std::size_t k = 0; k < contours.size(); ++k) {
        if (hierarchy[k][3] >= 0) continue;  // a hole
        const double a = std::abs(cv::contourArea(contours[k])) + static_cast<double>(contours[k].size()) * 1e-6;
        if (a > best_area) {
          best_area = a;
          best = k;
        }
      }
      if (contours.empty()) continue;
      std::vector<cv::Point> approx;
      cv::approxPolyDP(contours[best], approx, config.contour_epsilon_px, true);
      Polygon2 poly;
      auto add_point = [&](double x, double y) {
        poly.emplace_back(px_x(x + padded.x + 0.5), px_y(y + padded.y + 0.5));
      };
      if (approx.size() >= 3 && std::abs(cv::contourArea(approx)) > 0.5) {
        for (const cv::Point& p : approx) add_point(p.x, p.y);
      } else {
        // A sliver: use its rotated bounding rectangle grown to pixel edges.
        cv::RotatedRect rr = cv::minAreaRect(contours[best]);
        rr.size.width += 1.0f;
        rr.size.height += 1.0f;
        cv::Point2f corners[4];
        rr.points(corners);
        for (const cv::Point2f& p : corners) add_point(p.x, p.y);
      }
      if (polygon_signed_area(poly) < 0.0) std::reverse(poly.begin(), poly.end());
      // Holes (a corridor around a block of rooms, a pillar) are cut out of the footprint through a slit from its
      // nearest outer vertex, so it stays one polygon: the even-odd test and the shoelace area see outer minus
      // holes, and a room inside a corridor's ring is no longer inside the corridor's footprint.
      if (best_area >= 0.0 && hierarchy[best][2] >= 0 && poly.size() >= 3) {
        for (int k = hierarchy[best][2]; k >= 0; k = hierarchy[static_cast<std::size_t>(k)][0]) {
          std::vector<cv::Point> hole_px;
          cv::approxPolyDP(contours[static_cast<std::size_t>(k)], hole_px, config.contour_epsilon_px, true);
          if (hole_px.size() < 3 || std::abs(cv::contourArea(hole_px)) < config.min_hole_area_px) continue;
          Polygon2 hole;
          for (const cv::Point& p : hole_px) hole.emplace_back(px_x(p.x + padded.x + 0.5), px_y(p.y + padded.y + 0.5));
          if (polygon_signed_area(hole) > 0.0) std::reverse(hole.begin(), hole.end());
          cut_hole(&poly, hole);
          ++stats.room_holes;
        }
      }
      Room room;
      room.id = static_cast<std::int32_t>(world.rooms.size());
      room.label = kRoomUnknown;
      room.footprint_m = {poly};
      room.floor_z_m = 0.0;
      room.height_m = h;
      room.floor_index = 0;
      room_of_label[static_cast<std::size_t>(i)] = room.id;
      world.rooms.push_back(room);
    }
    stats.rooms = static_cast<int>(world.rooms.size());

    // Doors: separator pixels (not room interior in the ground truth, but free in the occupancy map) with two
    // different rooms nearby. Pixels are grouped per room pair, then into connected pieces.
    std::map<std::pair<int, int>, std::vector<cv::Point>> pair_pixels;
    const int R = std::max(1, config.separator_search_px);
    for (int r = 0; r < rows; ++r) {
      const std::uint8_t* g = gt.ptr<std::uint8_t>(r);
      const std::uint8_t* o = occ.ptr<std::uint8_t>(r);
      for (int c = 0; c < cols; ++c) {
        if (g[c] > config.gt_room_threshold || o[c] < config.free_threshold) continue;
        int found[8];
        int nfound = 0;
        for (int dy = -R; dy <= R; ++dy) {
          const int rr = r + dy;
          if (rr < 0 || rr >= rows) continue;
          const int* lrow = labels.ptr<int>(rr);
          for (int dx = -R; dx <= R; ++dx) {
            const int cc = c + dx;
            if (cc < 0 || cc >= cols) continue;
            const int room = room_of_label[static_cast<std::size_t>(lrow[cc])];
            if (room < 0) continue;
            if (std::find(found, found + nfound, room) == found + nfound && nfound < 8) found[nfound++] = room;
          }
        }
        for (int a = 0; a < nfound; ++a)
          for (int b = a + 1; b < nfound; ++b)
            pair_pixels[{std::min(found[a], found[b]), std::max(found[a], found[b])}].push_back({c, r});
      }
    }
    for (const auto& [pair, pixels] : pair_pixels) {
      const cv::Rect box = cv::boundingRect(pixels);
      cv::Mat mask = cv::Mat::zeros(box.size(), CV_8U);
      for (const cv::Point& p : pixels) mask.at<std::uint8_t>(p - box.tl()) = 255;
      cv::Mat piece_labels;
      const int pieces = cv::connectedComponents(mask, piece_labels, 8, CV_32S);
      std::vector<std::vector<Eigen::Vector2d>> groups(static_cast<std::size_t>(pieces));
      for (const cv::Point& p : pixels)
        groups[static_cast<std::size_t>(piece_labels.at<int>(p - box.tl()))].emplace_back(p.x + 0.5, p.y + 0.5);
      for (int k = 1; k < pieces; ++k) {
        const std::vector<Eigen::Vector2d>& pts = groups[static_cast<std::size_t>(k)];
        Eigen::Vector2d mean = Eigen::Vector2d::Zero();
        for (const Eigen::Vector2d& p : pts) mean += p;
        mean /= static_cast<double>(pts.size());
        Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
        for (const Eigen::Vector2d& p : pts) cov += (p - mean) * (p - mean).transpose();
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
        const Eigen::Vector2d dir = eig.eigenvectors().col(1);
        double lo = 1e300, hi = -1e300;
        for (const Eigen::Vector2d& p : pts) {
          lo = std::min(lo, (p - mean).dot(dir));
          hi = std::max(hi, (p - mean).dot(dir));
        }
        lo -= 0.5;
        hi += 0.5;
        const double length_px = hi - lo;
        // A doorway is a thin line: its pixel count is a few times its length at most.
        if (length_px * res < config.min_door_width_m) continue;
        if (static_cast<double>(pts.size()) > (2.0 * R + 1.0) * length_px) continue;
        const Eigen::Vector2d a = mean + lo * dir, b = mean + hi * dir;
        Door door;
        door.a_m = Eigen::Vector2d(px_x(a.x()), px_y(a.y()));
        door.b_m = Eigen::Vector2d(px_x(b.x()), px_y(b.y()));
        door.floor_z_m = 0.0;
        door.height_m = config.door_height_m;
        door.room_a = pair.first;
        door.room_b = pair.second;
        world.doors.push_back(door);
      }
    }
    stats.doors = static_cast<int>(world.doors.size());
  }
  if (stats_out) *stats_out = stats;
  result.ok = true;
  return result;
}

bool read_floor_plan_image(const std::string& path, const char* what, const FloorPlanConfig& config, cv::Mat* out,
                           std::string* error) {
  int w = 0, h = 0;
  if (!read_image_size(path, &w, &h, error)) return false;
  if (const std::string bad = image_size_error(w, h, config); !bad.empty()) {
    *error = path + ": " + bad;
    return false;
  }
  try {
    *out = cv::imread(path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    *error = path + ": cannot decode the " + what + " image (" + e.what() + ")";
    return false;
  }
  if (out->empty()) {
    *error = path + ": cannot read the " + what + " image";
    return false;
  }
  if (out->cols != w || out->rows != h) {  // the header reader and the decoder must agree; refuse if they do not
    *error = path + ": the " + what + " image decodes to " + std::to_string(out->cols) + " x " +
             std::to_string(out->rows) + " px but its header says " + std::to_string(w) + " x " + std::to_string(h);
    out->release();
    return false;
  }
  return true;
}

namespace {

// Reads a plan's images as grey: the occupancy image (required) and the ground truth (when gt_path is not empty).
bool read_plan_images(const std::string& occupancy_path, const std::string& gt_path, const FloorPlanConfig& config,
                      cv::Mat* occupancy, cv::Mat* gt, std::string* error) {
  if (!read_floor_plan_image(occupancy_path, "occupancy", config, occupancy, error)) return false;
  if (gt_path.empty()) return true;
  return read_floor_plan_image(gt_path, "ground-truth", config, gt, error);
}

}  // namespace

WorldResult import_furnished_floor_plan_files(const std::string& plain_path, const std::string& furnished_path,
                                              const std::string& gt_path, const FloorPlanConfig& config,
                                              FloorPlanStats* stats) {
  WorldResult result;
  cv::Mat plain, furnished, gt, unused;
  if (!read_plan_images(plain_path, "", config, &plain, &unused, &result.error) ||
      !read_plan_images(furnished_path, gt_path, config, &furnished, &gt, &result.error))
    return result;
  if (plain.size() != furnished.size()) {
    result.error = furnished_path + ": not the size of " + plain_path;
    return result;
  }
  // Furniture: occupied in the furnished plan, free in the plain one.
  const cv::Mat mask = (furnished < config.free_threshold) & (plain >= config.free_threshold);
  result = import_floor_plan(furnished, gt, config, stem_of(furnished_path), stats, mask);
  if (!result.ok) result.error = furnished_path + ": " + result.error;
  return result;
}

WorldResult import_floor_plan_files(const std::string& occupancy_path, const std::string& gt_path,
                                    const FloorPlanConfig& config, FloorPlanStats* stats) {
  WorldResult result;
  cv::Mat occ, gt;
  if (!read_plan_images(occupancy_path, gt_path, config, &occ, &gt, &result.error)) return result;
  result = import_floor_plan(occ, gt, config, stem_of(occupancy_path), stats);
  if (!result.ok) result.error = occupancy_path + ": " + result.error;
  return result;
}

}  // namespace qsg::world
