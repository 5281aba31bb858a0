#include "bench/rooms/floor_plan_rooms.h"

#include "core/rooms/room_finder.h"

#include <algorithm>
#include <deque>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace qsg::bench {

bool read_plan_raster(const std::string& occupancy_path, const std::string& gt_path,
                      const world::FloorPlanConfig& config, PlanRaster* out, std::string* error) {
  cv::Mat occ, gt;
  std::string why;
  if (!world::read_floor_plan_image(occupancy_path, "occupancy", config, &occ, &why) ||
      !world::read_floor_plan_image(gt_path, "ground-truth", config, &gt, &why)) {
    if (error != nullptr) *error = why;
    return false;
  }
  if (occ.size() != gt.size()) {
    if (error != nullptr)
      *error = occupancy_path + ": the plan and its ground truth (" + gt_path + ") differ in size";
    return false;
  }
  cv::Mat labels, stats, centroids;
  const cv::Mat white = gt > config.gt_room_threshold;
  cv::connectedComponentsWithStats(white, labels, stats, centroids, 8, CV_32S);
  out->cols = occ.cols;
  out->rows = occ.rows;
  out->free.assign(static_cast<std::size_t>(occ.total()), 0);
  out->truth.assign(out->free.size(), 0);
  for (int r = 0; r < occ.rows; ++r)
    for (int c = 0; c < occ.cols; ++c) {
      const std::size_t k = static_cast<std::size_t>(r) * occ.cols + c;
      out->free[k] = occ.at<std::uint8_t>(r, c) >= config.free_threshold ? 1 : 0;
      const int l = labels.at<int>(r, c);
      out->truth[k] = l > 0 && stats.at<int>(l, cv::CC_STAT_AREA) >= config.min_room_area_px ? l : 0;
    }
  return true;
}

void RoomSegmentationScore::add(const RoomSegmentationScore& o) {
  p_sum += o.p_sum;
  r_sum += o.r_sum;
  p_overlap += o.p_overlap;
  p_size += o.p_size;
  r_overlap += o.r_overlap;
  r_size += o.r_size;
  rooms_found += o.rooms_found;
  rooms_truth += o.rooms_truth;
  finish();
}

void RoomSegmentationScore::finish() {
  precision_mean = rooms_found > 0 ? p_sum / static_cast<double>(rooms_found) : 0.0;
  recall_mean = rooms_truth > 0 ? r_sum / static_cast<double>(rooms_truth) : 0.0;
  precision_area = p_size > 0 ? p_overlap / p_size : 0.0;
  recall_area = r_size > 0 ? r_overlap / r_size : 0.0;
}

RoomSegmentationScore score_room_segmentation(const std::vector<std::uint8_t>& free,
                                              const std::vector<std::int32_t>& truth,
                                              const std::vector<std::int32_t>& estimate) {
  RoomSegmentationScore s;
  if (free.size() != truth.size() || free.size() != estimate.size()) return s;
  std::map<std::pair<std::int32_t, std::int32_t>, double> overlap;
  std::map<std::int32_t, double> est_size, gt_size;
  for (std::size_t k = 0; k < free.size(); ++k) {
    if (!free[k] || truth[k] <= 0) continue;
    gt_size[truth[k]] += 1.0;
    if (estimate[k] <= 0) continue;
    est_size[estimate[k]] += 1.0;
    overlap[{estimate[k], truth[k]}] += 1.0;
  }
  std::map<std::int32_t, double> best_e, best_g;
  for (const auto& [key, n] : overlap) {
    best_e[key.first] = std::max(best_e[key.first], n);
    best_g[key.second] = std::max(best_g[key.second], n);
  }
  for (const auto& [e, n] : est_size) {
    s.p_sum += best_e[e] / n;
    s.p_overlap += best_e[e];
    s.p_size += n;
  }
  for (const auto& [g, n] : gt_size) {
    s.r_sum += best_g[g] / n;
    s.r_overlap += best_g[g];
    s.r_size += n;
  }
  s.rooms_found = est_size.size();
  s.rooms_truth = gt_size.size();
  s.finish();
  return s;
}

namespace {

// Wavefront: breadth first through free cells (8-connected) from every labelled cell at once, so each reachable free
// cell takes the label of its geodesically nearest seed.
void grow_rooms(const std::vector<std::uint8_t>& free, int cols, int rows, std::vector<std::int32_t>* labels) {
  std::deque<std::pair<int, int>> queue;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if ((*labels)[static_cast<std::size_t>(r) * cols + c] != 0) queue.emplace_back(c, r);
  while (!queue.empty()) {
    const auto [c, r] = queue.front();
    queue.pop_front();
    const std::int32_t room = (*labels)[static_cast<std::size_t>(r) * cols + c];
    for (int dr = -1; dr <= 1; ++dr)
      for (int dc = -1; dc <= 1; ++dc) {
        const int cc = c + dc, rr = r + dr;
        if (cc < 0 || rr < 0 || cc >= cols || rr >= rows) continue;
        const std::size_t k = static_cast<std::size_t>(rr) * cols + cc;
        if (!free[k] || (*labels)[k] != 0) continue;
        (*labels)[k] = room;
        queue.emplace_back(cc, rr);
      }
  }
}

bool check_raster(const std::vector<std::uint8_t>& free, int cols, int rows, const void* out, double resolution_m,
                  double min_area_m2, double max_area_m2, const char** error) {
  if (out == nullptr || cols <= 0 || rows <= 0 ||
      free.size() != static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows)) {
    *error = "plan segmentation: the raster's size does not match cols x rows";
    return false;
  }
  if (!(resolution_m > 0.0)) {
    *error = "plan segmentation: resolution_m must be positive";
    return false;
  }
  if (!(min_area_m2 >= 0.0) || !(max_area_m2 >= min_area_m2)) {
    *error = "plan segmentation: the room area range is empty";
    return false;
  }
  return true;
}

cv::Mat free_mask(const std::vector<std::uint8_t>& free, int cols, int rows) {
  cv::Mat mask(rows, cols, CV_8U);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      mask.at<std::uint8_t>(r, c) = free[static_cast<std::size_t>(r) * cols + c] ? 255 : 0;
  return mask;
}

}  // namespace

bool segment_by_distance_transform(const std::vector<std::uint8_t>& free, int cols, int rows,
                                   const DistanceSegmentationConfig& config, PlanSegmentation* out,
                                   const char** error) {
  const char* unused = nullptr;
  if (error == nullptr) error = &unused;
  if (!check_raster(free, cols, rows, out, config.resolution_m, config.min_room_area_m2, config.max_room_area_m2,
                    error))
    return false;
  if (!(config.step_m > 0.0)) {
    *error = "distance segmentation: step_m must be positive";
    return false;
  }
  if (!(config.plateau_alpha >= 0.0 && config.plateau_alpha <= 1.0)) {
    *error = "distance segmentation: plateau_alpha must lie in [0, 1]";
    return false;
  }
  if (!(config.plateau_min_level_m > 0.0 && config.plateau_max_level_m >= config.plateau_min_level_m)) {
    *error = "distance segmentation: the plateau range must be positive and not empty";
    return false;
  }
  const cv::Mat mask = free_mask(free, cols, rows);
  cv::Mat distance_px;
  cv::distanceTransform(mask, distance_px, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  double max_px = 0.0;
  cv::minMaxLoc(distance_px, nullptr, &max_px);
  const double cell_m2 = config.resolution_m * config.resolution_m;
  const auto room_sized = [&](int area_px) {
    const double a = area_px * cell_m2;
    return a >= config.min_room_area_m2 && a <= config.max_room_area_m2;
  };

  // The number of room-sized regions at every level (a Betti-0 curve of the room-sized regions).
  cv::Mat labels, stats, centroids;
  const double step_px = config.step_m / config.resolution_m;
  const auto count_at = [&](double t_px) {
    const cv::Mat above = distance_px > t_px;
    const int n = cv::connectedComponentsWithStats(above, labels, stats, centroids, 8, CV_32S);
    std::uint32_t count = 0;
    for (int l = 1; l < n; ++l) count += room_sized(stats.at<int>(l, cv::CC_STAT_AREA)) ? 1 : 0;
    return count;
  };
  std::vector<std::uint32_t> counts;
  for (int i = 1; i * step_px < max_px; ++i) counts.push_back(count_at(i * step_px));
  // The chosen level: the most regions (the lowest on ties), or the alpha plateau of the curve.
  int chosen = -1;
  if (config.level == DistanceSegmentationConfig::Level::kPlateau) {
    // counts[i] is the level (i + 1) x step; the curve over [min, max] level, clipped to the levels that exist.
    const double first_step = std::ceil(config.plateau_min_level_m / config.step_m - 1e-9);
    const auto first = static_cast<std::size_t>(std::max(0.0, first_step - 1.0));
    const auto last = std::min(counts.size(),
                               static_cast<std::size_t>(std::floor(config.plateau_max_level_m / config.step_m + 1e-9)));
    if (first < last) {
      const int run = rooms::choose_plateau(counts.data() + first, last - first, config.plateau_alpha);
      if (run >= 0) chosen = static_cast<int>(first) + run;
    }
  } else {
    for (std::size_t i = 0; i < counts.size(); ++i)
      if (counts[i] > 0 && (chosen < 0 || counts[i] > counts[static_cast<std::size_t>(chosen)]))
        chosen = static_cast<int>(i);
  }
  const int best_count = chosen < 0 ? 0 : static_cast<int>(counts[static_cast<std::size_t>(chosen)]);
  const double best_px = chosen < 0 ? 0.0 : (chosen + 1) * step_px;
  if (best_count > 0) count_at(best_px);  // the seeds: the chosen level's regions, left in labels and stats

  out->labels.assign(free.size(), 0);
  out->rooms = 0;
  out->level_m = best_px * config.resolution_m;
  if (best_count == 0) return true;
  std::vector<std::int32_t> room_of_component(static_cast<std::size_t>(stats.rows), 0);
  for (int l = 1; l < stats.rows; ++l)
    if (room_sized(stats.at<int>(l, cv::CC_STAT_AREA))) room_of_component[l] = ++out->rooms;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      out->labels[static_cast<std::size_t>(r) * cols + c] = room_of_component[labels.at<int>(r, c)];
  grow_rooms(free, cols, rows, &out->labels);
  return true;
}

bool segment_by_erosion(const std::vector<std::uint8_t>& free, int cols, int rows,
                        const MorphologicalSegmentationConfig& config, PlanSegmentation* out, const char** error) {
  const char* unused = nullptr;
  if (error == nullptr) error = &unused;
  if (!check_raster(free, cols, rows, out, config.resolution_m, config.min_room_area_m2, config.max_room_area_m2,
                    error))
    return false;
  const double cell_m2 = config.resolution_m * config.resolution_m;
  out->labels.assign(free.size(), 0);
  out->rooms = 0;
  out->level_m = 0.0;
  cv::Mat map = free_mask(free, cols, rows), labels, stats, centroids;
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3));
  for (int step = 1; cv::countNonZero(map) > 0; ++step) {
    cv::erode(map, map, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    const int n = cv::connectedComponentsWithStats(map, labels, stats, centroids, 8, CV_32S);
    std::vector<std::int32_t> room_of_component(static_cast<std::size_t>(n), 0);
    bool found = false;
    for (int l = 1; l < n; ++l) {
      const double a = stats.at<int>(l, cv::CC_STAT_AREA) * cell_m2;
      if (a >= config.min_room_area_m2 && a <= config.max_room_area_m2) {
        room_of_component[l] = ++out->rooms;
        found = true;
      }
    }
    if (!found) continue;
    out->level_m = step * config.resolution_m;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        const std::int32_t room = room_of_component[labels.at<int>(r, c)];
        if (room == 0) continue;
        out->labels[static_cast<std::size_t>(r) * cols + c] = room;
        map.at<std::uint8_t>(r, c) = 0;  // a room, out of further erosion
      }
  }
  grow_rooms(free, cols, rows, &out->labels);
  return true;
}

}  // namespace qsg::bench
