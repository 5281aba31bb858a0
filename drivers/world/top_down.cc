// Top-down drawing of a World with OpenCV: room fills, wall and stair footprints, objects, doors, names, scale bar.
#include "drivers/world/top_down.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "drivers/world/world_query.h"

namespace qsg::world {
namespace {

constexpr int kShift = 4;  // sub-pixel bits for fillPoly / polylines
constexpr double kSub = 1 << kShift;

cv::Point sub_px(const cv::Point2d& p) {
  return {static_cast<int>(std::lround(p.x * kSub)), static_cast<int>(std::lround(p.y * kSub))};
}

std::vector<cv::Point> to_px(const std::vector<Eigen::Vector2d>& poly, const TopDownFrame& f) {
  std::vector<cv::Point> out;
  out.reserve(poly.size());
  for (const Eigen::Vector2d& v : poly) out.push_back(sub_px(f.to_pixel(v.x(), v.y())));
  return out;
}

cv::Scalar hsv_color(double hue01, double sat01, double val01) {
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(hue01 * 180.0, sat01 * 255.0, val01 * 255.0));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return cv::Scalar(c[0], c[1], c[2]);
}

cv::Scalar rgb(const std::array<std::uint8_t, 3>& c) { return cv::Scalar(c[2], c[1], c[0]); }

// Footprint of a shape in the x-y plane (convex hull of box corners, cylinder as a polygon, prism polygon).
std::vector<Eigen::Vector2d> shape_footprint(const World& w, const Shape& s) {
  std::vector<Eigen::Vector2d> out;
  switch (s.kind) {
    case ShapeKind::kBox: {
      if (s.index >= w.boxes.size()) break;
      const BoxShape& b = w.boxes[s.index];
      // Boxes that only turn about z (most walls) keep their exact rectangle.
      if (b.world_R_box.x() == 0.0 && b.world_R_box.y() == 0.0) return box_footprint(b);
      const Eigen::Matrix3d R = b.world_R_box.normalized().toRotationMatrix();
      std::vector<cv::Point2f> pts;
      for (int i = 0; i < 8; ++i) {
        const Eigen::Vector3d corner(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
        const Eigen::Vector3d p = b.center_m + R * corner.cwiseProduct(b.half_extents_m);
        pts.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
      }
      std::vector<cv::Point2f> hull;
      cv::convexHull(pts, hull);
      for (const cv::Point2f& p : hull) out.emplace_back(p.x, p.y);
      break;
    }
    case ShapeKind::kCylinder: {
      if (s.index >= w.cylinders.size()) break;
      const CylinderShape& c = w.cylinders[s.index];
      for (int i = 0; i < 16; ++i) {
        const double a = 2.0 * 3.14159265358979 * i / 16.0;
        out.emplace_back(c.base_center_m.x() + c.radius_m * std::cos(a),
                         c.base_center_m.y() + c.radius_m * std::sin(a));
      }
      break;
    }
    case ShapeKind::kPrism:
      if (s.index < w.prisms.size()) out = w.prisms[s.index].polygon_m;
      break;
    case ShapeKind::kPlane: break;
  }
  return out;
}

struct Band {
  double z0 = -1e300, z1 = 1e300;
  bool overlaps(const Aabb& b) const { return b.max_m.z() > z0 + 0.05 && b.min_m.z() < z1 - 0.05; }
};

Band floor_band(const World& w, int floor_index) {
  Band band;
  if (floor_index < 0) return band;
  bool any = false;
  double z0 = 1e300, z1 = -1e300;
  for (const Room& r : w.rooms)
    if (r.floor_index == floor_index) {
      any = true;
      z0 = std::min(z0, r.floor_z_m);
      z1 = std::max(z1, r.floor_z_m + r.height_m);
    }
  if (any) {
    band.z0 = z0;
    band.z1 = z1;
  }
  return band;
}

bool is_structure_drawn(semantics::Label l) { return l != semantics::kFloor && l != semantics::kCeiling; }

}  // namespace

void TopDownStyle::print(std::FILE* out) const {
  std::fprintf(out,
               "TopDownStyle: pixels_per_m=%.1f margin_px=%d floor_index=%d max_side_px=%d fill_rooms=%d draw_walls=%d "
               "draw_doors=%d draw_objects=%d draw_room_names=%d draw_scale_bar=%d\n",
               pixels_per_m, margin_px, floor_index, max_side_px, fill_rooms, draw_walls, draw_doors, draw_objects,
               draw_room_names, draw_scale_bar);
}

cv::Scalar room_label_color(semantics::RoomLabel label) {
  if (label == semantics::kRoomUnknown || label >= semantics::kNumRoomLabels) return cv::Scalar(215, 215, 215);
  // Golden-ratio hue steps keep neighbouring labels far apart; alternate value for more separation.
  const double hue = std::fmod(label * 0.6180339887, 1.0);
  return hsv_color(hue, label % 2 ? 0.35 : 0.5, label % 3 == 0 ? 0.88 : 0.97);
}

TopDownFrame top_down_frame(const World& world, const TopDownStyle& style) {
  Aabb b = world_bounds(world);
  if (b.empty()) {
    b.extend(Eigen::Vector3d::Zero());
    b.extend(Eigen::Vector3d(1.0, 1.0, 1.0));
  }
  TopDownFrame f;
  const double ex = std::max(b.max_m.x() - b.min_m.x(), 1e-3), ey = std::max(b.max_m.y() - b.min_m.y(), 1e-3);
  const int margin = std::max(style.margin_px, 0);
  double ppm = style.pixels_per_m > 0.0 ? style.pixels_per_m : 40.0;
  const double usable = std::max(style.max_side_px - 2 * margin, 16);
  ppm = std::min(ppm, usable / std::max(ex, ey));
  f.pixels_per_m = ppm;
  // The epsilon keeps 8.1 m * 20 px/m from rounding up to 163 px.
  f.width_px = static_cast<int>(std::ceil(ex * ppm - 1e-6)) + 2 * margin;
  f.height_px = static_cast<int>(std::ceil(ey * ppm - 1e-6)) + 2 * margin;
  f.origin_x_m = b.min_m.x() - margin / ppm;
  f.origin_y_m = b.max_m.y() + margin / ppm;
  return f;
}

cv::Mat draw_top_down(const World& world, const TopDownStyle& style, TopDownFrame* frame_out) {
  using namespace semantics;
  const TopDownFrame f = top_down_frame(world, style);
  if (frame_out) *frame_out = f;
  cv::Mat img(f.height_px, f.width_px, CV_8UC3, rgb(style.background_rgb));
  const Band band = floor_band(world, style.floor_index);
  auto on_floor = [&](const Room& r) { return style.floor_index < 0 || r.floor_index == style.floor_index; };
  const double ppm = f.pixels_per_m;

  if (style.fill_rooms) {
    for (const Room& r : world.rooms) {
      if (!on_floor(r)) continue;
      const cv::Scalar color = r.label == kRoomUnknown ? hsv_color(std::fmod(r.id * 0.6180339887, 1.0), 0.3, 0.97)
                                                       : room_label_color(r.label);
      std::vector<std::vector<cv::Point>> polys;
      for (const Polygon2& p : r.footprint_m) polys.push_back(to_px(p, f));
      cv::fillPoly(img, polys, color, cv::LINE_AA, kShift);
      cv::polylines(img, polys, true, color * 0.8, 1, cv::LINE_AA, kShift);
    }
  }
  if (style.draw_walls) {
    // Stairs and railings first (lighter), walls over them.
    for (int pass = 0; pass < 2; ++pass) {
      for (const Shape& s : world.shapes) {
        if (s.object_id >= 0 || s.kind == ShapeKind::kPlane || !is_structure_drawn(s.material.label)) continue;
        const bool wall = s.material.label != kStairs && s.material.label != kRailing;
        if (wall != (pass == 1)) continue;
        if (!band.overlaps(shape_bounds(world, s))) continue;
        const std::vector<Eigen::Vector2d> fp = shape_footprint(world, s);
        if (fp.size() < 3) continue;
        const std::vector<cv::Point> px = to_px(fp, f);
        if (wall) {
          cv::fillConvexPoly(img, px, cv::Scalar(45, 45, 45), cv::LINE_8, kShift);
        } else {
          cv::fillConvexPoly(img, px, s.material.label == kStairs ? cv::Scalar(200, 185, 170) : cv::Scalar(90, 90, 90),
                             cv::LINE_AA, kShift);
          cv::polylines(img, std::vector<std::vector<cv::Point>>{px}, true, cv::Scalar(110, 100, 90), 1, cv::LINE_AA,
                        kShift);
        }
      }
    }
  }
  if (style.draw_objects) {
    for (const Object& o : world.objects) {
      bool show = true;
      if (style.floor_index >= 0) {
        if (o.room_id >= 0 && static_cast<std::size_t>(o.room_id) < world.rooms.size() &&
            world.rooms[static_cast<std::size_t>(o.room_id)].id == o.room_id)
          show = on_floor(world.rooms[static_cast<std::size_t>(o.room_id)]);
        else
          show = o.box.center_m.z() >= band.z0 && o.box.center_m.z() <= band.z1;
      }
      if (!show) continue;
      const std::vector<cv::Point> px = to_px(box_footprint(o.box), f);
      const cv::Scalar color = rgb(object_label(o.label).color);
      cv::fillConvexPoly(img, px, color, cv::LINE_AA, kShift);
      cv::polylines(img, std::vector<std::vector<cv::Point>>{px}, true, color * 0.5, 1, cv::LINE_AA, kShift);
    }
  }
  if (style.draw_doors) {
    const int thick = std::max(2, static_cast<int>(std::lround(0.12 * ppm)));
    for (const Door& d : world.doors) {
      if (style.floor_index >= 0 && (d.floor_z_m < band.z0 - 1e-6 || d.floor_z_m >= band.z1)) continue;
      const cv::Point a = sub_px(f.to_pixel(d.a_m.x(), d.a_m.y())), b = sub_px(f.to_pixel(d.b_m.x(), d.b_m.y()));
      cv::line(img, a, b, cv::Scalar(40, 170, 40), thick, cv::LINE_AA, kShift);
      cv::circle(img, a, static_cast<int>(thick * kSub * 0.7), cv::Scalar(0, 110, 0), -1, cv::LINE_AA, kShift);
      cv::circle(img, b, static_cast<int>(thick * kSub * 0.7), cv::Scalar(0, 110, 0), -1, cv::LINE_AA, kShift);
    }
  }
  if (style.draw_room_names) {
    const double scale = std::clamp(ppm / 60.0, 0.3, 0.6);
    for (const Room& r : world.rooms) {
      if (!on_floor(r) || r.footprint_m.empty() || r.footprint_m[0].empty()) continue;
      // Label at the polygon's area centroid.
      const Polygon2& p = r.footprint_m[0];
      double a = 0.0, cx = 0.0, cy = 0.0;
      for (std::size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) {
        const double cross = p[j].x() * p[i].y() - p[i].x() * p[j].y();
        a += cross;
        cx += (p[j].x() + p[i].x()) * cross;
        cy += (p[j].y() + p[i].y()) * cross;
      }
      if (std::abs(a) < 1e-12) continue;
      cx /= 3.0 * a;
      cy /= 3.0 * a;
      const std::string text =
          std::to_string(r.id) + (r.label == kRoomUnknown ? "" : std::string(" ") + room_label_name(r.label));
      int baseline = 0;
      const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline);
      const cv::Point2d c = f.to_pixel(cx, cy);
      cv::putText(img, text, cv::Point(static_cast<int>(c.x - size.width / 2), static_cast<int>(c.y + size.height / 2)),
                  cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(30, 30, 30), 1, cv::LINE_AA);
    }
  }
  if (style.draw_scale_bar) {
    // The longest "nice" length that fits in a fifth of the picture.
    const double target_m = 0.2 * (f.width_px - 2 * style.margin_px) / ppm;
    double bar_m = 0.1;
    for (double nice : {0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0})
      if (nice <= target_m) bar_m = nice;
    const int len = static_cast<int>(std::lround(bar_m * ppm));
    const int x0 = std::max(4, style.margin_px / 2), y0 = f.height_px - std::max(6, style.margin_px / 3);
    cv::rectangle(img, cv::Point(x0, y0 - 4), cv::Point(x0 + len, y0), cv::Scalar(0, 0, 0), -1);
    char text[32];
    std::snprintf(text, sizeof(text), bar_m < 1.0 ? "%.1f m" : "%.0f m", bar_m);
    cv::putText(img, text, cv::Point(x0 + len + 6, y0), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
  }
  return img;
}

bool write_png(const cv::Mat& image, const std::string& path, std::string* error) {
  try {
    if (image.empty()) {
      if (error) *error = path + ": image is empty";
      return false;
    }
    if (!cv::imwrite(path, image)) {
      if (error) *error = path + ": cannot write PNG";
      return false;
    }
  } catch (const cv::Exception& e) {
    if (error) *error = path + ": cannot write PNG (" + e.what() + ")";
    return false;
  }
  return true;
}

bool write_top_down_png(const World& world, const TopDownStyle& style, const std::string& path, std::string* error) {
  return write_png(draw_top_down(world, style), path, error);
}

void draw_polyline(cv::Mat& image, const std::vector<Eigen::Vector3d>& points_m, const TopDownFrame& frame,
                   const cv::Scalar& color_bgr, int thickness_px) {
  if (points_m.size() < 2 || image.empty()) return;
  std::vector<cv::Point> px;
  px.reserve(points_m.size());
  for (const Eigen::Vector3d& p : points_m) px.push_back(sub_px(frame.to_pixel(p.x(), p.y())));
  cv::polylines(image, std::vector<std::vector<cv::Point>>{px}, false, color_bgr, std::max(1, thickness_px),
                cv::LINE_AA, kShift);
}

void draw_points(cv::Mat& image, const std::vector<Eigen::Vector3d>& points_m, const TopDownFrame& frame,
                 const cv::Scalar& color_bgr, int radius_px) {
  if (image.empty()) return;
  for (const Eigen::Vector3d& p : points_m)
    cv::circle(image, sub_px(frame.to_pixel(p.x(), p.y())), static_cast<int>(std::max(1, radius_px) * kSub), color_bgr,
               -1, cv::LINE_AA, kShift);
}

}  // namespace qsg::world
