// segmentation_eval: what segmentation costs and how good its labels are, per camera resolution, and what labelling
// only some keyframes (the segmentation worker's rate) does to the map's labels.
//
//  1. Cost and pixel accuracy on the simulator's rendered frames (per-pixel ground-truth labels) at 320x240,
//     384x384 and 640x480: per frame the thread's CPU time and wall time of segment() on one OpenCV thread, the
//     heap allocations (malloc interposer, every thread), and against the truth, over the classes the network can
//     name (chair, table, sofa, tv_monitor, plant, objects; everything else is "other"): pixel accuracy, per-class
//     IoU and their mean over the classes present in the truth.
//  2. Real frames (../shared/data: TUM, NYU, SUN RGB-D, Redwood, ICL-NUIM, Kinect): they carry no per-pixel truth,
//     so the figures are the label histogram and the agreement of labels computed from the frame downscaled to
//     320x240 with those from the full frame (what a lower camera resolution changes).
//  3. The map: one tour integrated into the semantic TSDF with every keyframe labelled, and with only every Nth
//     keyframe labelled through late votes (SemanticTsdf::integrate_label_votes, one keyframe later, as the worker
//     delivers them); mesh vertex labels compared with those of the every-keyframe map. Once with the renderer's
//     true labels (the rate's own effect, a perfect segmenter) and once with the network's.
//  4. Network input size: ESPNetv2 (PASCAL) is exported for a fixed 384x384 input (its pyramid pooling is a
//     constant matrix product), so frames of any size are resized to it; the fully convolutional ESPNet
//     (Cityscapes, outdoor classes) runs at the frame's own size: its forward cost at each size, for comparison.
//
//   segmentation_eval [--model F] [--city-model F] [--rooms N] [--seed N] [--frames N] [--every N] [--json F]
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <sys/stat.h>
#include <unordered_map>
#include <vector>

#include "bench/figures.h"
#include "bench/segmentation/malloc_count.h"
#include "bench/sim_tour.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/segmentation/segmenter.h"
#include "drivers/world/building_generator.h"

namespace {

using namespace qsg;

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

std::string shared_dir() {
  const char* env = std::getenv("QSG_SHARED_DATA");
  return env != nullptr && exists(env) ? env : std::string(QSG_SOURCE_DIR) + "/../shared/data";
}

std::int64_t thread_cpu_us() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1000000 + t.tv_nsec / 1000;
}

double wall_ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The classes the PASCAL network can name in mpcat40, and "other" for everything else.
constexpr int kEvalClasses = 7;
constexpr const char* kEvalNames[kEvalClasses] = {"chair", "table", "sofa", "tv_monitor", "plant", "objects", "other"};
int eval_class(semantics::Label l) {
  switch (l) {
    case semantics::kChair: return 0;
    case semantics::kTable: return 1;
    case semantics::kSofa: return 2;
    case semantics::kTvMonitor: return 3;
    case semantics::kPlant: return 4;
    case semantics::kObjects: return 5;
    default: return 6;
  }
}

struct Confusion {
  std::array<std::array<std::uint64_t, kEvalClasses>, kEvalClasses> m{};  // [truth][predicted]
  void add(semantics::Label truth, semantics::Label predicted) { ++m[eval_class(truth)][eval_class(predicted)]; }
  std::uint64_t total() const {
    std::uint64_t n = 0;
    for (const auto& r : m)
      for (std::uint64_t v : r) n += v;
    return n;
  }
  double accuracy() const {
    std::uint64_t ok = 0;
    for (int c = 0; c < kEvalClasses; ++c) ok += m[c][c];
    return total() ? static_cast<double>(ok) / static_cast<double>(total()) : 0.0;
  }
  std::uint64_t truth_of(int c) const {
    std::uint64_t n = 0;
    for (int p = 0; p < kEvalClasses; ++p) n += m[c][p];
    return n;
  }
  double iou(int c) const {
    std::uint64_t fp = 0, fn = 0;
    for (int k = 0; k < kEvalClasses; ++k)
      if (k != c) fp += m[k][c], fn += m[c][k];
    const std::uint64_t d = m[c][c] + fp + fn;
    return d ? static_cast<double>(m[c][c]) / static_cast<double>(d) : 0.0;
  }
  // Mean IoU over the network's object classes present in the truth ("other" left out: it is the background).
  double miou(int* classes) const {
    double sum = 0.0;
    int n = 0;
    for (int c = 0; c + 1 < kEvalClasses; ++c)
      if (truth_of(c) > 0) sum += iou(c), ++n;
    if (classes != nullptr) *classes = n;
    return n ? sum / n : 0.0;
  }
  // Of the truth's object pixels (any class but other), the share given their own class.
  double object_recall() const {
    std::uint64_t ok = 0, n = 0;
    for (int c = 0; c + 1 < kEvalClasses; ++c) ok += m[c][c], n += truth_of(c);
    return n ? static_cast<double>(ok) / static_cast<double>(n) : 0.0;
  }
};

struct Resolution {
  int width, height;
  std::string name() const { return std::to_string(width) + "x" + std::to_string(height); }
};

bool load_rgb(const std::string& path, messages::RgbdFrame* frame, int width = 0, int height = 0) {
  cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
  if (bgr.empty()) return false;
  if (width > 0) cv::resize(bgr, bgr, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  if (bgr.cols > messages::kMaxFrameWidth || bgr.rows > messages::kMaxFrameHeight)
    cv::resize(bgr, bgr, cv::Size(640, 480), 0, 0, cv::INTER_AREA);
  const double f = 525.0 * bgr.cols / 640.0;
  frame->intrinsics = {bgr.cols, bgr.rows, f, f, 0.5 * bgr.cols - 0.5, 0.5 * bgr.rows - 0.5};
  cv::Mat rgb(bgr.rows, bgr.cols, CV_8UC3, frame->rgb.data());
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  frame->has_labels = false;
  return true;
}

struct Options {
  std::string model, city_model, json;
  int rooms = 4;
  std::uint64_t seed = 7;
  int frames = 40;     // sim frames segmented per resolution
  int map_frames = 150;  // keyframes of the map comparison
  int every = 5;
};

// Mesh vertex labels of `map` compared with those of `reference` (same depth, so the same vertices by key).
Confusion compare_maps(reconstruction::SemanticTsdf& reference, reconstruction::SemanticTsdf& map,
                       std::uint64_t* unmatched) {
  std::unordered_map<std::uint64_t, semantics::Label> ref;
  reference.for_each_block([&](std::uint32_t h, const reconstruction::SemanticTsdf::BlockView&) {
    reconstruction::SemanticTsdf::VertexCursor cur;
    reconstruction::MeshVertex v;
    std::uint64_t key = 0;
    while (reference.next_block_vertex(h, &cur, &v, &key)) ref[key] = v.label;
  });
  Confusion c;
  map.for_each_block([&](std::uint32_t h, const reconstruction::SemanticTsdf::BlockView&) {
    reconstruction::SemanticTsdf::VertexCursor cur;
    reconstruction::MeshVertex v;
    std::uint64_t key = 0;
    while (map.next_block_vertex(h, &cur, &v, &key)) {
      const auto it = ref.find(key);
      if (it == ref.end()) {
        ++*unmatched;
        continue;
      }
      c.add(it->second, v.label);
    }
  });
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  o.model = shared_dir() + "/models/espnetv2_s2_pascal384.onnx";
  o.city_model = shared_dir() + "/models/espnet_p2q8_city.onnx";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--model" && has) o.model = argv[++i];
    else if (a == "--city-model" && has) o.city_model = argv[++i];
    else if (a == "--json" && has) o.json = argv[++i];
    else if (a == "--rooms" && has) o.rooms = std::atoi(argv[++i]);
    else if (a == "--seed" && has) o.seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--frames" && has) o.frames = std::atoi(argv[++i]);
    else if (a == "--map-frames" && has) o.map_frames = std::atoi(argv[++i]);
    else if (a == "--every" && has) o.every = std::max(1, std::atoi(argv[++i]));
    else {
      std::printf("usage: segmentation_eval [--model F] [--city-model F] [--rooms N] [--seed N] [--frames N] "
                  "[--map-frames N] [--every N] [--json F]\n");
      return a == "--help" ? 0 : 2;
    }
  }
  if (!exists(o.model)) {
    std::fprintf(stderr, "segmentation_eval: model '%s' not found (../shared/data/models or --model)\n", o.model.c_str());
    return 2;
  }
  segmentation::LabelMap map;
  std::string error;
  if (!map.load(std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json", &error)) {
    std::fprintf(stderr, "segmentation_eval: %s\n", error.c_str());
    return 2;
  }
  segmentation::Config sc;
  sc.model_path = o.model;
  sc.opencv_threads = 1;  // one core: the target's condition
  segmentation::Segmenter seg;
  if (!seg.init(sc, map, &error)) {
    std::fprintf(stderr, "segmentation_eval: %s\n", error.c_str());
    return 2;
  }
  char conditions[256];
  std::snprintf(conditions, sizeof conditions,
                "ESPNetv2 PASCAL (384x384 input), 1 OpenCV thread, min_confidence %.2f; sim: %d-room building seed %llu",
                sc.min_confidence, o.rooms, static_cast<unsigned long long>(o.seed));
  bench::Figures figures(conditions);
  auto frame = std::make_unique<messages::RgbdFrame>();
  auto truth = std::make_unique<std::array<std::uint16_t, messages::kMaxFramePixels>>();

  world::BuildingConfig bc;
  bc.num_rooms = o.rooms;
  bc.seed = o.seed;
  const world::World w = world::generate_building(bc);

  // 1. Cost and pixel accuracy per resolution on rendered frames.
  std::printf("1. sim frames: per-frame cost (thread CPU, 1 OpenCV thread) and accuracy against the renderer's labels\n");
  std::printf("  %-8s %6s %9s %9s %9s %9s %8s %8s %8s   per-class IoU\n", "size", "frames", "cpu_ms", "cpu_p95",
              "wall_ms", "allocs", "acc_%", "mIoU_%", "objrec_%");
  for (const Resolution r : {Resolution{320, 240}, Resolution{384, 384}, Resolution{640, 480}}) {
    sim::ExplorationConfig ec;
    sim::SimCamera::Config cc;
    cc.intrinsics = bench::camera_of_size(r.width, r.height);
    cc.rate_hz = 0.5;  // frames 2 s apart along the tour: different views
    bench::SimTour tour;
    if (!bench::make_sim_tour(w, ec, cc, render::Renderer::Config{}, &tour, &error)) {
      std::fprintf(stderr, "segmentation_eval: %s\n", error.c_str());
      return 2;
    }
    Confusion conf;
    std::vector<double> cpu_ms, wall_ms, allocs;
    int n = 0;
    while (n < o.frames) {
      const drivers::ReadStatus s = tour.camera->read(*frame, 0);
      if (s == drivers::ReadStatus::kEndOfStream) break;
      if (s != drivers::ReadStatus::kOk || !frame->has_labels) continue;
      const int px = frame->pixels();
      std::copy(frame->labels.begin(), frame->labels.begin() + px, truth->begin());
      frame->has_labels = false;
      const std::int64_t a0 = bench::heap_allocations();
      const std::int64_t c0 = thread_cpu_us();
      const auto w0 = std::chrono::steady_clock::now();
      if (!seg.segment(*frame, &error)) {
        std::fprintf(stderr, "segmentation_eval: %s\n", error.c_str());
        return 2;
      }
      wall_ms.push_back(wall_ms_since(w0));
      cpu_ms.push_back(static_cast<double>(thread_cpu_us() - c0) * 1e-3);
      allocs.push_back(static_cast<double>(bench::heap_allocations() - a0));
      for (int i = 0; i < px; ++i) conf.add((*truth)[static_cast<std::size_t>(i)], frame->labels[static_cast<std::size_t>(i)]);
      ++n;
    }
    double cpu = 0, wall = 0, al = 0;
    for (std::size_t i = 0; i < cpu_ms.size(); ++i) cpu += cpu_ms[i], wall += wall_ms[i], al += allocs[i];
    const double k = std::max<double>(1.0, static_cast<double>(cpu_ms.size()));
    int present = 0;
    const double miou = conf.miou(&present);
    std::printf("  %-8s %6d %9.1f %9.1f %9.1f %9.0f %8.1f %8.1f %8.1f  ", r.name().c_str(), n, cpu / k,
                bench::quantile(cpu_ms, 0.95), wall / k, bench::heap_allocations() < 0 ? -1.0 : al / k,
                100 * conf.accuracy(), 100 * miou, 100 * conf.object_recall());
    for (int c = 0; c + 1 < kEvalClasses; ++c)
      if (conf.truth_of(c) > 0) std::printf(" %s %.1f", kEvalNames[c], 100 * conf.iou(c));
    std::printf("\n");
    const std::string p = "segmentation.sim_" + r.name();
    figures.add(p + ".frames", n, "frames");
    figures.add(p + ".cpu_ms_mean", cpu / k, "ms");
    figures.add(p + ".cpu_ms_p95", bench::quantile(cpu_ms, 0.95), "ms");
    figures.add(p + ".wall_ms_mean", wall / k, "ms");
    figures.add(p + ".heap_allocations_per_frame", bench::heap_allocations() < 0 ? -1.0 : al / k, "allocations");
    figures.add(p + ".pixel_accuracy", 100 * conf.accuracy(), "%");
    figures.add(p + ".miou_object_classes", 100 * miou, "%");
    figures.add(p + ".object_classes_present", present, "classes");
    figures.add(p + ".object_pixel_recall", 100 * conf.object_recall(), "%");
    for (int c = 0; c < kEvalClasses; ++c) {
      figures.add(p + ".truth_share." + kEvalNames[c],
                  100.0 * static_cast<double>(conf.truth_of(c)) / std::max<double>(1.0, static_cast<double>(conf.total())), "%");
      std::uint64_t predicted = 0;
      for (int t = 0; t < kEvalClasses; ++t) predicted += conf.m[t][c];
      figures.add(p + ".predicted_share." + kEvalNames[c],
                  100.0 * static_cast<double>(predicted) / std::max<double>(1.0, static_cast<double>(conf.total())), "%");
    }
  }

  // 2. Real frames: histogram, and agreement of labels from the 320x240 frame with labels from the full frame.
  std::printf("2. real frames (no per-pixel truth in ../shared/data): labels from the frame at 320x240 against "
              "labels from the full frame\n");
  const std::string rgbd = shared_dir() + "/rgbd/";
  std::vector<std::string> real = {rgbd + "redwood_open3d/RGBD/other_formats/TUM_color.png",
                                   rgbd + "redwood_open3d/RGBD/other_formats/NYU_color.ppm",
                                   rgbd + "redwood_open3d/RGBD/other_formats/SUN_color.jpg"};
  for (int k = 0; k < 5; ++k) {
    real.push_back(rgbd + "redwood_open3d/RGBD/color/0000" + std::to_string(k) + ".jpg");
    real.push_back(rgbd + "icl_nuim_livingroom5/color/" + std::to_string(k + 1) + ".png");
    real.push_back(rgbd + "kinect5/color/" + std::to_string(k + 1) + ".png");
  }
  auto small = std::make_unique<messages::RgbdFrame>();
  std::uint64_t agree = 0, total = 0, object_full = 0, object_small = 0, object_both = 0;
  double real_cpu_ms = 0.0;
  int real_frames = 0;
  for (const std::string& path : real) {
    if (!load_rgb(path, frame.get()) || !load_rgb(path, small.get(), 320, 240)) continue;
    const std::int64_t c0 = thread_cpu_us();
    if (!seg.segment(*frame, &error)) continue;
    real_cpu_ms += static_cast<double>(thread_cpu_us() - c0) * 1e-3;
    if (!seg.segment(*small, &error)) continue;
    ++real_frames;
    std::uint64_t fo = 0, so = 0, bo = 0, ag = 0;
    const int W = frame->width(), H = frame->height();
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const semantics::Label a = frame->labels[static_cast<std::size_t>(v * W + u)];
        const int su = std::min(319, u * 320 / W), sv = std::min(239, v * 240 / H);
        const semantics::Label b = small->labels[static_cast<std::size_t>(sv * 320 + su)];
        const bool oa = eval_class(a) != 6, ob = eval_class(b) != 6;
        fo += oa, so += ob, bo += oa && ob && eval_class(a) == eval_class(b);
        ag += eval_class(a) == eval_class(b);
      }
    agree += ag, total += static_cast<std::uint64_t>(W) * H, object_full += fo, object_small += so, object_both += bo;
    std::printf("  %-60s %dx%d object px full %5.1f %% 320x240 %5.1f %% agree %5.1f %%\n",
                path.substr(rgbd.size()).c_str(), W, H, 100.0 * fo / (W * H), 100.0 * so / (W * H),
                100.0 * ag / (W * H));
  }
  if (real_frames > 0) {
    const double iou = object_full + object_small > object_both
                           ? static_cast<double>(object_both) / static_cast<double>(object_full + object_small - object_both)
                           : 1.0;
    std::printf("  %d frames: label agreement 320x240 vs full %.1f %%, object-pixel IoU %.1f %%, full-frame cpu %.1f ms\n",
                real_frames, 100.0 * agree / total, 100 * iou, real_cpu_ms / real_frames);
    figures.add("segmentation.real.frames", real_frames, "frames");
    figures.add("segmentation.real.agreement_320x240_vs_full", 100.0 * agree / total, "%");
    figures.add("segmentation.real.object_iou_320x240_vs_full", 100 * iou, "%");
    figures.add("segmentation.real.object_share_full", 100.0 * object_full / total, "%");
    figures.add("segmentation.real.cpu_ms_mean_full", real_cpu_ms / real_frames, "ms");
  }

  // 3. The map with every keyframe labelled against every Nth keyframe labelled late, for N in 2 (what one x86
  // core gives at 5 Hz keyframes), o.every (the budget's 1 in 5) and 2 * o.every.
  {
    const std::vector<int> rates = {2, o.every, 2 * o.every};
    std::printf("3. map labels: every keyframe labelled vs every Nth keyframe labelled one keyframe late "
                "(320x240, 5 Hz keyframes, %d keyframes)\n", o.map_frames);
    sim::ExplorationConfig ec;
    sim::SimCamera::Config cc;
    cc.intrinsics = bench::camera_of_size(320, 240);
    cc.rate_hz = 5.0;
    bench::SimTour tour;
    if (!bench::make_sim_tour(w, ec, cc, render::Renderer::Config{}, &tour, &error)) {
      std::fprintf(stderr, "segmentation_eval: %s\n", error.c_str());
      return 2;
    }
    reconstruction::Config rc;
    rc.window_radius_m = 500.0;  // keep every block: the whole tour is compared
    reconstruction::Capacities caps = reconstruction::capacities_from_budget();
    caps.max_blocks = 8192;
    const std::size_t bytes = reconstruction::SemanticTsdf::plan(caps).total_bytes();
    const auto make = [&]() {
      auto t = std::make_unique<reconstruction::SemanticTsdf>();
      if (!t->init(rc, caps, bytes, &error)) t.reset();
      return t;
    };
    // truth_all: the renderer's labels on every keyframe (the reference); net_all: the network's on every keyframe;
    // per rate N, truth_late / net_late: labels of every Nth keyframe only, voted one keyframe late.
    auto truth_all = make(), net_all = make();
    std::vector<std::unique_ptr<reconstruction::SemanticTsdf>> truth_late, net_late;
    for (std::size_t r = 0; r < rates.size(); ++r) truth_late.push_back(make()), net_late.push_back(make());
    bool ok = truth_all && net_all;
    for (std::size_t r = 0; r < rates.size(); ++r) ok = ok && truth_late[r] && net_late[r];
    if (!ok) {
      std::fprintf(stderr, "segmentation_eval: %s\n", error.c_str());
      return 2;
    }
    auto pending_truth = std::make_unique<messages::RgbdFrame>();
    auto pending_net = std::make_unique<messages::RgbdFrame>();
    Eigen::Isometry3d pending_pose = Eigen::Isometry3d::Identity();
    int pending_n = -1;
    int n = 0;
    bench::for_each_posed_frame(tour, *frame, [&](messages::RgbdFrame& f, const Eigen::Isometry3d& pose, std::int64_t,
                                                  const Eigen::Isometry3d&) {
      if (n >= o.map_frames || !f.has_labels) return;
      // Late votes of the keyframe labelled last time (the worker's labels come back during the next keyframe).
      if (pending_n >= 0) {
        for (std::size_t r = 0; r < rates.size(); ++r)
          if (pending_n % rates[r] == 0) {
            truth_late[r]->integrate_label_votes(*pending_truth, pending_pose);
            net_late[r]->integrate_label_votes(*pending_net, pending_pose);
          }
        pending_n = -1;
      }
      truth_all->process(f, pose);  // with the renderer's labels
      *pending_truth = f;
      f.has_labels = false;
      for (std::size_t r = 0; r < rates.size(); ++r) {
        truth_late[r]->process(f, pose);  // geometry only
        net_late[r]->process(f, pose);
      }
      seg.segment(f, &error);     // the network's labels of this keyframe
      net_all->process(f, pose);  // the same geometry, the network's labels
      *pending_net = f;
      pending_pose = pose;
      pending_n = n;
      ++n;
    });
    truth_all->update_mesh();
    net_all->update_mesh();
    for (std::size_t r = 0; r < rates.size(); ++r) truth_late[r]->update_mesh(), net_late[r]->update_mesh();
    std::uint64_t unmatched = 0;
    const Confusion net_full = compare_maps(*truth_all, *net_all, &unmatched);
    std::printf("  %d keyframes, %llu mesh vertices\n", n, static_cast<unsigned long long>(net_full.total()));
    std::printf("  network, every keyframe vs truth: accuracy %.1f %%, mIoU %.1f %%, object recall %.1f %%\n",
                100 * net_full.accuracy(), 100 * net_full.miou(nullptr), 100 * net_full.object_recall());
    figures.add("segmentation.map.keyframes", n, "keyframes");
    figures.add("segmentation.map.vertices", static_cast<double>(net_full.total()), "vertices");
    figures.add("segmentation.map_every_1.network_accuracy_vs_truth", 100 * net_full.accuracy(), "%");
    figures.add("segmentation.map_every_1.network_miou_vs_truth", 100 * net_full.miou(nullptr), "%");
    figures.add("segmentation.map_every_1.network_object_recall_vs_truth", 100 * net_full.object_recall(), "%");
    for (std::size_t r = 0; r < rates.size(); ++r) {
      const Confusion truth_rate = compare_maps(*truth_all, *truth_late[r], &unmatched);
      const Confusion net_rate = compare_maps(*truth_all, *net_late[r], &unmatched);
      const Confusion net_vs_net = compare_maps(*net_all, *net_late[r], &unmatched);
      std::printf("  every %2dth keyframe, late: true labels agree with every-keyframe true labels on %.2f %% of "
                  "vertices (object mIoU %.1f %%); network vs truth accuracy %.1f %%, mIoU %.1f %%, object recall "
                  "%.1f %%; network agrees with every-keyframe network on %.2f %%\n",
                  rates[r], 100 * truth_rate.accuracy(), 100 * truth_rate.miou(nullptr), 100 * net_rate.accuracy(),
                  100 * net_rate.miou(nullptr), 100 * net_rate.object_recall(), 100 * net_vs_net.accuracy());
      const std::string p = "segmentation.map_every_" + std::to_string(rates[r]);
      figures.add(p + ".truth_labels_agreement_with_every_keyframe", 100 * truth_rate.accuracy(), "%");
      figures.add(p + ".truth_labels_miou_vs_every_keyframe", 100 * truth_rate.miou(nullptr), "%");
      figures.add(p + ".network_accuracy_vs_truth", 100 * net_rate.accuracy(), "%");
      figures.add(p + ".network_miou_vs_truth", 100 * net_rate.miou(nullptr), "%");
      figures.add(p + ".network_object_recall_vs_truth", 100 * net_rate.object_recall(), "%");
      figures.add(p + ".network_agreement_with_every_keyframe", 100 * net_vs_net.accuracy(), "%");
    }
    figures.add("segmentation.map.vertices_unmatched", static_cast<double>(unmatched), "vertices");
  }

  // 4. Forward cost per network input size (OpenCV alone, one thread, thread CPU time, 3 runs after a warm-up).
  std::printf("4. forward pass alone per input size (thread CPU, 1 OpenCV thread)\n");
  const auto forward_cost = [&](const std::string& model, int w_px, int h_px, double* ms) {
    try {
      cv::dnn::Net net = cv::dnn::readNetFromONNX(model);
      const int shape[4] = {1, 3, h_px, w_px};
      cv::Mat blob(4, shape, CV_32F, cv::Scalar(0.1));
      net.setInput(blob);
      net.forward();
      const std::int64_t c0 = thread_cpu_us();
      for (int k = 0; k < 3; ++k) {
        net.setInput(blob);
        net.forward();
      }
      *ms = static_cast<double>(thread_cpu_us() - c0) * 1e-3 / 3.0;
      return true;
    } catch (const cv::Exception&) {
      return false;
    }
  };
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);  // a refused shape logs every layer
  for (const auto& [model, name] : {std::pair{o.model, std::string("espnetv2_pascal")},
                                    std::pair{o.city_model, std::string("espnet_city")}}) {
    if (!exists(model)) continue;
    for (const Resolution r : {Resolution{320, 240}, Resolution{384, 384}, Resolution{640, 480}}) {
      double ms = 0.0;
      const bool ok = forward_cost(model, r.width, r.height, &ms);
      std::printf("  %-16s input %-8s %s\n", name.c_str(), r.name().c_str(),
                  ok ? (std::to_string(static_cast<int>(ms + 0.5)) + " ms").c_str()
                     : "refused (fixed 384x384 input: the export's constant pooling matrices)");
      figures.add("segmentation.forward_" + name + "_" + r.name() + ".cpu_ms", ok ? ms : -1.0, "ms");
    }
  }
  if (!o.json.empty() && !figures.write(o.json)) return 2;
  return 0;
}
