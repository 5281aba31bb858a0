// Top-down picture of the scene graph.
#include "firmware_app/graph_picture.h"

#include <algorithm>
#include <cmath>
#include <new>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "core/semantics/labels.h"
#include "drivers/world/top_down.h"
#include "firmware_app/pipeline.h"

namespace qsg::app {

namespace {
// The frame around every node of the graph when there is no world to frame it.
world::TopDownFrame frame_around(const scene_graph::SceneGraph& graph, const std::vector<Eigen::Vector3d>& trajectory_m,
                                 int max_side_px) {
  Eigen::Vector2d lo(1e18, 1e18), hi(-1e18, -1e18);
  const auto grow = [&](const Eigen::Vector3d& p) {
    // A non-finite or absurd point (farther than any robot goes) is drawn clipped, not framed.
    constexpr double kFarthest_m = 1e7;
    if (!(p.head<2>().cwiseAbs().maxCoeff() <= kFarthest_m)) return;
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  };
  for (const Eigen::Vector3d& p : trajectory_m) grow(p);
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kPlace) grow(graph.place(n.id)->position_m);
    if (n.kind == scene_graph::NodeKind::kObject) grow(graph.object(n.id)->position_m);
  });
  if (lo.x() > hi.x()) lo = hi = Eigen::Vector2d::Zero();
  world::TopDownFrame f;
  const double margin_m = 1.0;
  const double extent = std::max(hi.x() - lo.x(), hi.y() - lo.y()) + 2 * margin_m;
  // 2000 px across by default, 5 .. 80 px/m, and never more than max_side_px a side whatever the extent.
  f.pixels_per_m = std::min(std::clamp(2000.0 / std::max(extent, 1.0), 5.0, 80.0), (max_side_px - 1) / extent);
  f.origin_x_m = lo.x() - margin_m;
  f.origin_y_m = hi.y() + margin_m;
  f.width_px = std::min(max_side_px, static_cast<int>(std::ceil((hi.x() - lo.x() + 2 * margin_m) * f.pixels_per_m)));
  f.height_px = std::min(max_side_px, static_cast<int>(std::ceil((hi.y() - lo.y() + 2 * margin_m) * f.pixels_per_m)));
  return f;
}
}  // namespace

namespace {

// Far-off points are drawn at the clamped position (off the canvas, which OpenCV clips) rather than overflowing int.
cv::Point to_int_pixel(const cv::Point2d& q) {
  constexpr double kLimit = 1e6;
  const auto clamp = [&](double v) { return std::isfinite(v) ? std::clamp(v, -kLimit, kLimit) : -kLimit; };
  return cv::Point(static_cast<int>(std::lround(clamp(q.x))), static_cast<int>(std::lround(clamp(q.y))));
}

// Each room's name at its node, dark on a white outline so it reads over any fill: the label's name once the room
// is labelled, its node name ("R(3)") until then.
void draw_room_names(const scene_graph::SceneGraph& graph, const world::TopDownFrame& frame, cv::Mat& image) {
  const double scale = std::clamp(frame.pixels_per_m / 50.0, 0.4, 1.6);
  const int thickness = std::max(1, static_cast<int>(std::lround(2 * scale)));
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    const scene_graph::RoomAttributes* r = graph.room(n.id);
    if (r == nullptr) return;
    const std::string name = r->semantic_label != semantics::kRoomUnknown && r->semantic_label < semantics::kNumRoomLabels
                                 ? semantics::room_label_name(static_cast<semantics::RoomLabel>(r->semantic_label))
                                 : std::string(r->name.c_str(), r->name.size());
    int baseline = 0;
    const cv::Size size = cv::getTextSize(name, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &baseline);
    const cv::Point at = to_int_pixel(frame.to_pixel(r->position_m.x(), r->position_m.y())) - cv::Point(size.width / 2, -size.height / 2);
    cv::putText(image, name, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255), thickness + 3, cv::LINE_AA);
    cv::putText(image, name, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(40, 40, 40), thickness, cv::LINE_AA);
  });
}

cv::Mat draw_graph_picture(const scene_graph::SceneGraph& graph, const world::World& world,
                           const std::vector<Eigen::Vector3d>& trajectory_m, const GraphPictureConfig& config) {
  world::TopDownFrame frame;
  cv::Mat image;
  if (!world.shapes.empty()) {
    world::TopDownStyle style;
    style.fill_rooms = false;  // the plan as a faint background: the graph is the subject
    style.draw_objects = false;
    style.draw_room_names = false;
    style.max_side_px = config.max_side_px;
    image = world::draw_top_down(world, style, &frame);
  } else {
    frame = frame_around(graph, trajectory_m, config.max_side_px);
    image = cv::Mat(frame.height_px, frame.width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  }
  const auto px = [&](const Eigen::Vector3d& p) { return to_int_pixel(frame.to_pixel(p.x(), p.y())); };
  // Rooms: their places' hull would need the places; a disc at the room node and the room's label colour.
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kRoom) return;
    const scene_graph::RoomAttributes* r = graph.room(n.id);
    // By label once the room is classified; until then a distinct pastel per room, so rooms can be told apart.
    cv::Scalar color = world::room_label_color(static_cast<semantics::RoomLabel>(r->semantic_label));
    if (r->semantic_label == semantics::kRoomUnknown) {
      const std::uint64_t h = (n.id & 0xFFFFFFFFFFFFFFull) * 0x9E3779B97F4A7C15ull;
      color = cv::Scalar(140 + static_cast<double>((h >> 20) & 0x5F), 140 + static_cast<double>((h >> 32) & 0x5F),
                         140 + static_cast<double>((h >> 44) & 0x5F));
    }
    graph.for_each_child(n.id, [&](scene_graph::NodeId child) {
      if (const scene_graph::PlaceAttributes* p = graph.place(child))
        cv::circle(image, px(p->position_m), std::max(3, static_cast<int>(0.4 * frame.pixels_per_m)), color, cv::FILLED);
    });
  });
  // Place edges, then places.
  graph.for_each_edge([&](const scene_graph::EdgeRecord& e) {
    const scene_graph::PlaceAttributes* a = graph.place(e.source);
    const scene_graph::PlaceAttributes* b = graph.place(e.target);
    if (a != nullptr && b != nullptr) cv::line(image, px(a->position_m), px(b->position_m), cv::Scalar(230, 170, 90), 1, cv::LINE_AA);
  });
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (const scene_graph::PlaceAttributes* p = graph.place(n.id))
      cv::circle(image, px(p->position_m), 3, p->is_active ? cv::Scalar(200, 110, 0) : cv::Scalar(150, 150, 150),
                 cv::FILLED, cv::LINE_AA);
  });
  // Objects: their boxes.
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    const scene_graph::ObjectAttributes* o = graph.object(n.id);
    if (o == nullptr) return;
    const scene_graph::BoundingBox& b = o->bounding_box;
    if (b.type != scene_graph::BoundingBox::Type::kInvalid)
      cv::rectangle(image, px(Eigen::Vector3d(b.min_m.x(), b.max_m.y(), 0)), px(Eigen::Vector3d(b.max_m.x(), b.min_m.y(), 0)),
                    cv::Scalar(0, 150, 0), 2, cv::LINE_AA);
    cv::circle(image, px(o->position_m), 3, cv::Scalar(0, 110, 0), cv::FILLED, cv::LINE_AA);
  });
  world::draw_polyline(image, trajectory_m, frame, cv::Scalar(30, 30, 220), 1);
  if (config.draw_room_names) draw_room_names(graph, frame, image);
  return image;
}

}  // namespace

bool write_graph_picture(const scene_graph::SceneGraph& graph, const world::World& world,
                         const std::vector<Eigen::Vector3d>& trajectory_m, const std::string& path, std::string* error,
                         const GraphPictureConfig& config) {
  if (config.max_side_px < 256 || config.max_side_px > 16384) {
    *error = path + ": GraphPictureConfig::max_side_px must be in [256, 16384]";
    return false;
  }
  std::vector<unsigned char> png;
  try {
    const cv::Mat image = draw_graph_picture(graph, world, trajectory_m, config);
    if (!cv::imencode(".png", image, png)) {
      *error = path + ": cannot encode the PNG";
      return false;
    }
  } catch (const cv::Exception& e) {
    *error = path + ": cannot draw the picture (" + e.what() + ")";
    return false;
  } catch (const std::bad_alloc&) {
    *error = path + ": cannot draw the picture (out of memory)";
    return false;
  }
  return write_file_atomically(path, std::string(png.begin(), png.end()), error);
}

}  // namespace qsg::app
