// Objects evaluation: explores generated buildings with the simulated robot (ground-truth poses, or drifting ones
// with --odometry sim|vio, noise-free depth, ground-truth labels, 0.1 m voxels), runs the app's semantic TSDF and
// frontend (objects, places, agents: bench/eval_harness.h) on every keyframe, and prints objects % found and %
// correct (same label, position within 0.5 m of the ground truth's, in the world frame) and the per-update time of
// the frontend (the object layer's alone: bm_objects).
//
// Definitions: a ground-truth object is "found" when an estimated object of its label has its position within
// 0.5 m of the ground-truth box centre; an estimated object is "correct" when it matches some ground-truth object
// that way. The position scored is the one the scene graph reports (the object node's position_m, read back from
// the graph); the same figures with the objects' vertex means are printed for comparison. "Observed" ground-truth
// objects are those with at least 20 mesh vertices of their label inside their box (inflated by 0.15 m) in the
// final mesh: objects the robot never saw cannot be found by any method.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench/eval_harness.h"
#include "bench/figures.h"
#include "bench/objects/object_match.h"
#include "bench/sim_tour.h"
#include "budgets/budget_table.h"
#include "core/objects/object_layer.h"
#include "core/objects/objects_params.h"
#include "core/params/params.h"
#include "core/reconstruction/reconstruction_params.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/scene_graph.h"
#include "drivers/world/building_generator.h"

namespace {

using namespace qsg;

struct Options {
  std::vector<std::uint64_t> seeds = {1, 2, 3};
  int rooms = 8;
  int width = 320;
  int height = 240;
  double spacing_m = 0.25;  // keyframe spacing along the path at the tour's speed
  double tolerance_m = 0.0;  // > 0 overrides every label's clustering tolerance
  std::string json_path;
  bench::OdometryOption odometry;  // --odometry gt|sim|vio, --odometry-seed N
  objects::Config objects;         // --set objects.KEY=VALUE, from its parameter table (core/objects/objects_params)
  reconstruction::Config reconstruction;  // --set reconstruction.KEY=VALUE (core/reconstruction/reconstruction_params)
  std::string settings;                   // the --set assignments, for the figures' conditions
};

const std::vector<params::Section>& objects_sections() {
  static const std::vector<params::Section> sections = params::sections_of("objects", objects::params_table());
  return sections;
}

const std::vector<params::Section>& reconstruction_sections() {
  static const std::vector<params::Section> sections =
      params::sections_of("reconstruction", reconstruction::params_table());
  return sections;
}

void usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--seeds 1,2,3 | --seeds 4 5 6] [--rooms N] [--size WxH] [--spacing-m S] [--tolerance-m T] "
               "%s [--set objects.KEY=VALUE | reconstruction.KEY=VALUE ...] [--json FILE]\n"
               "  Objects of the app's pipeline on generated buildings against the simulator's ground truth: found,\n"
               "  correct, merges, time (objects_eval.*). --odometry gt|sim|vio: drivers/sim/odometry_levels.h.\n",
               argv0, bench::odometry_usage());
  std::fprintf(stderr, "Settings (--set objects.KEY=VALUE or reconstruction.KEY=VALUE):\n");
  params::print_help(objects_sections(), stderr);
  params::print_help(reconstruction_sections(), stderr);
}

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return false;
    if (const int odometry = bench::parse_odometry_flag(argc, argv, &i, &o->odometry)) {
      if (odometry < 0) return false;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "option %s needs a value\n", a.c_str());
      return false;
    }
    const char* v = argv[++i];
    char* end = nullptr;
    if (a == "--seeds") {
      o->seeds.clear();
      std::stringstream ss(v);
      std::string item;
      // Comma- or space-separated: "--seeds 1,2,3" or "--seeds 4 5 6" (values up to the next option).
      for (;;) {
        while (std::getline(ss, item, ',')) {
          const std::uint64_t s = std::strtoull(item.c_str(), &end, 10);
          if (item.empty() || *end != '\0') {
            std::fprintf(stderr, "--seeds: bad seed '%s'\n", item.c_str());
            return false;
          }
          o->seeds.push_back(s);
        }
        if (i + 1 >= argc || std::string(argv[i + 1]).rfind("--", 0) == 0) break;
        ss.clear();
        ss.str(argv[++i]);
      }
      continue;
    } else if (a == "--rooms") {
      o->rooms = static_cast<int>(std::strtol(v, &end, 10));
    } else if (a == "--tolerance-m") {
      o->tolerance_m = std::strtod(v, &end);
    } else if (a == "--spacing-m") {
      o->spacing_m = std::strtod(v, &end);
    } else if (a == "--json") {
      o->json_path = v;
      continue;
    } else if (a == "--size") {
      if (std::sscanf(v, "%dx%d", &o->width, &o->height) != 2) {
        std::fprintf(stderr, "--size: expected WxH, got '%s'\n", v);
        return false;
      }
      continue;
    } else if (a == "--set") {
      std::string error;
      const std::string assignment = v;
      const bool ok =
          assignment.rfind("reconstruction.", 0) == 0
              ? params::set(reconstruction_sections(), &o->reconstruction, assignment, &error)
              : params::set(objects_sections(), &o->objects,
                            "objects." + assignment.substr(assignment.rfind("objects.", 0) == 0 ? 8 : 0), &error);
      if (!ok) {
        std::fprintf(stderr, "--set %s\n", error.c_str());
        return false;
      }
      o->settings += (o->settings.empty() ? "" : " ") + assignment;
      continue;
    } else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return false;
    }
    if (end == v || *end != '\0') {
      std::fprintf(stderr, "option %s: bad number '%s'\n", a.c_str(), v);
      return false;
    }
  }
  if (o->seeds.empty() || o->rooms < 3 || !(o->spacing_m > 0.0) || o->width < 16 || o->width > 640 ||
      o->height < 16 || o->height > 480) {
    std::fprintf(stderr, "bad option value (seeds not empty, rooms >= 3, spacing > 0, size 16x16 to 640x480)\n");
    return false;
  }
  return true;
}

using bench::quantile;


struct Score {
  std::size_t gt = 0, observed = 0, found = 0, found_observed = 0, estimated = 0, correct = 0;
  std::size_t found_mean = 0, correct_mean = 0;  // scored with the vertex mean instead, for comparison
  // Merges by rule and the merge search's work, summed over the buildings.
  std::uint64_t merged_centre = 0, merged_intersect = 0, merged_size = 0, index_queries = 0, index_visits = 0;
};

bool run_building(std::uint64_t seed, const Options& opt, Score* score, std::vector<double>* update_ms,
                  std::vector<double>* update_cpu_ms, std::vector<double>* recon_ms, std::size_t* keyframes) {
  world::BuildingConfig bc;
  bc.num_rooms = opt.rooms;
  bc.seed = seed;
  const world::World w = world::generate_building(bc);
  const sim::ExplorationConfig ec;
  sim::SimCamera::Config cc;
  cc.intrinsics = bench::camera_of_size(opt.width, opt.height);
  cc.rate_hz = ec.speed_m_s / opt.spacing_m;
  bench::SimTour sim_tour;
  std::string error;
  if (!bench::make_sim_tour(w, ec, cc, render::Renderer::Config{}, &sim_tour, &error)) {
    std::fprintf(stderr, "seed %llu: %s\n", static_cast<unsigned long long>(seed), error.c_str());
    return false;
  }
  bench::set_odometry(opt.odometry, seed, &sim_tour);
  const sim::ExplorationResult& tour = sim_tour.tour;

  // The app's stages (bench/eval_harness.h): the frontend (objects, places, agents) on the TSDF every keyframe.
  bench::PipelineConfig config;
  config.reconstruction = opt.reconstruction;
  objects::Config& oc = config.frontend.objects;
  oc = opt.objects;
  if (opt.tolerance_m > 0.0)
    for (objects::LabelParams& p : oc.labels) p.tolerance_m = opt.tolerance_m;
  auto graph = std::make_unique<scene_graph::SceneGraph>();
  if (!graph->init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "scene graph: %s\n", error.c_str());
    return false;
  }
  bench::EvalPipeline pipeline;
  if (!pipeline.init(config, graph.get(), &error)) {
    std::fprintf(stderr, "pipeline: %s\n", error.c_str());
    return false;
  }
  const objects::ObjectLayer& layer = pipeline.frontend().objects();
  if (seed == opt.seeds.front()) {
    config.reconstruction.print(stdout);
    oc.print(stdout);
    layer.capacities().print(stdout);
  }
  const std::size_t frames = pipeline.explore(sim_tour, [&](const bench::FrontendStep& step) {
    update_cpu_ms->push_back(step.update_cpu_ms);
    update_ms->push_back(step.update_ms);
  });
  recon_ms->insert(recon_ms->end(), pipeline.integrate_ms().begin(), pipeline.integrate_ms().end());
  *keyframes += frames;

  reconstruction::Mesh mesh;
  pipeline.tsdf().extract_full_mesh(&mesh);
  Score s;
  s.gt = w.objects.size();
  const std::vector<int> mesh_vertices = bench::object_mesh_vertices(w, mesh);
  std::vector<bool> observed(w.objects.size(), false);
  for (std::size_t i = 0; i < w.objects.size(); ++i) observed[i] = mesh_vertices[i] >= bench::kObservedMinVertices;
  // The visits kept apart merged, as at the app's finish; then score what the scene graph reports for each node (and,
  // for comparison, the layer's vertex means: of a merged node, its surviving visit's).
  const objects::RevisitMerge visits = pipeline.merge_object_visits();
  visits.print(stdout);
  bool graph_consistent = true;
  std::vector<objects::ObjectView> views;
  std::vector<bench::EstimatedObject> reported, means;
  graph->for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kObject) return;
    objects::ObjectView est;
    if (!layer.find_object(n.id, &est)) {
      graph_consistent = false;
      return;
    }
    const scene_graph::ObjectAttributes* attr = graph->object(n.id);
    est.min_m = attr->bounding_box.min_m;  // the box the graph reports (a merged node's covers every visit)
    est.max_m = attr->bounding_box.max_m;
    views.push_back(est);
    reported.push_back({est.label, attr->position_m});
    means.push_back({est.label, est.vertex_mean_m});
  });
  const bench::ObjectMatch match = bench::match_objects(w, reported);
  const bench::ObjectMatch match_mean = bench::match_objects(w, means);
  const std::vector<bool>& found = match.found;
  const std::vector<bool>& found_mean = match_mean.found;
  s.estimated = views.size();
  s.correct = match.num_correct;
  s.correct_mean = match_mean.num_correct;
  for (std::size_t j = 0; j < views.size(); ++j) {
    if (match.correct[j]) continue;
    const objects::ObjectView& est = views[j];
    const Eigen::Vector3d& position = reported[j].position_m;
    std::printf("  seed %llu: incorrect estimate %s at (%.2f %.2f %.2f), box size (%.2f %.2f %.2f), %llu vertices",
                static_cast<unsigned long long>(seed), semantics::object_label(est.label).name, position.x(),
                position.y(), position.z(), est.max_m.x() - est.min_m.x(), est.max_m.y() - est.min_m.y(),
                est.max_m.z() - est.min_m.z(), static_cast<unsigned long long>(est.num_vertices));
    // The nearest ground-truth object of its label, with its world-aligned box, to tell a fragment from noise.
    const world::Object* nearest = nullptr;
    for (const world::Object& o : w.objects)
      if (o.label == est.label &&
          (nearest == nullptr || (o.box.center_m - position).norm() < (nearest->box.center_m - position).norm()))
        nearest = &o;
    if (nearest != nullptr) {
      const Eigen::Vector3d e = nearest->box.world_R_box.toRotationMatrix().cwiseAbs() * nearest->box.half_extents_m;
      std::printf("; nearest %s %.2f m away, world box (%.2f %.2f %.2f)..(%.2f %.2f %.2f)",
                  semantics::object_label(nearest->label).name, (nearest->box.center_m - position).norm(),
                  nearest->box.center_m.x() - e.x(), nearest->box.center_m.y() - e.y(),
                  nearest->box.center_m.z() - e.z(), nearest->box.center_m.x() + e.x(),
                  nearest->box.center_m.y() + e.y(), nearest->box.center_m.z() + e.z());
    }
    std::printf("; estimated box (%.2f %.2f %.2f)..(%.2f %.2f %.2f)\n", est.min_m.x(), est.min_m.y(), est.min_m.z(),
                est.max_m.x(), est.max_m.y(), est.max_m.z());
  }
  if (!graph_consistent) {
    std::fprintf(stderr, "seed %llu: an object node of the scene graph is not one of the layer's objects\n",
                 static_cast<unsigned long long>(seed));
    return false;
  }
  for (std::size_t i = 0; i < w.objects.size(); ++i) {
    s.observed += observed[i] ? 1 : 0;
    s.found += found[i] ? 1 : 0;
    s.found_observed += (found[i] && observed[i]) ? 1 : 0;
    s.found_mean += found_mean[i] ? 1 : 0;
    if (!found[i])
      std::printf("  seed %llu: missed %s%s at (%.2f %.2f %.2f), size (%.2f %.2f %.2f), %d mesh vertices of its label "
                  "in its box\n",
                  static_cast<unsigned long long>(seed), semantics::object_label(w.objects[i].label).name,
                  observed[i] ? "" : " (never observed)", w.objects[i].box.center_m.x(), w.objects[i].box.center_m.y(),
                  w.objects[i].box.center_m.z(), 2 * w.objects[i].box.half_extents_m.x(),
                  2 * w.objects[i].box.half_extents_m.y(), 2 * w.objects[i].box.half_extents_m.z(), mesh_vertices[i]);
  }
  std::printf("seed %llu: %zu rooms, tour %.1f m, %zu keyframes; ground truth %zu objects (%zu observed), found %zu; "
              "estimated %zu, correct %zu; agents %zu, graph objects %zu\n",
              static_cast<unsigned long long>(seed), w.rooms.size(), tour.length_m, frames, s.gt, s.observed, s.found,
              s.estimated, s.correct, pipeline.frontend().agents().num_keyframes(), graph->num_nodes(scene_graph::NodeKind::kObject));
  layer.counters().print(stdout);
  layer.for_each_resource([](const memory::ResourceStats& r) {
    std::printf("  ");
    r.print(stdout);
  });
  score->gt += s.gt;
  score->observed += s.observed;
  score->found += s.found;
  score->found_observed += s.found_observed;
  score->estimated += s.estimated;
  score->correct += s.correct;
  score->found_mean += s.found_mean;
  score->correct_mean += s.correct_mean;
  const objects::Counters& oc_counters = layer.counters();
  score->merged_centre += oc_counters.objects_overlap_merged + oc_counters.clusters_overlap_merged;
  score->merged_intersect += oc_counters.objects_intersect_merged;
  score->merged_size += oc_counters.objects_size_merged;
  score->index_queries += oc_counters.index_queries;
  score->index_visits += oc_counters.index_visits;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) {
    usage(argv[0]);
    return 2;
  }
  Score score;
  std::vector<double> update_ms, update_cpu_ms, recon_ms;
  std::size_t keyframes = 0;
  for (const std::uint64_t seed : opt.seeds)
    if (!run_building(seed, opt, &score, &update_ms, &update_cpu_ms, &recon_ms, &keyframes)) return 1;
  if (update_ms.empty() || score.gt == 0) {
    std::fprintf(stderr, "nothing evaluated\n");
    return 1;
  }
  const auto pct = [](std::size_t a, std::size_t b) { return b == 0 ? 0.0 : 100.0 * static_cast<double>(a) / b; };
  const double found_pct = pct(score.found, score.gt);
  const double found_observed_pct = pct(score.found_observed, score.observed);
  const double correct_pct = pct(score.correct, score.estimated);
  const double median = quantile(update_ms, 0.5), p99 = quantile(update_ms, 0.99);
  const double max_ms = *std::max_element(update_ms.begin(), update_ms.end());
  const double cpu_median = quantile(update_cpu_ms, 0.5), cpu_p99 = quantile(update_cpu_ms, 0.99);
  const double cpu_max = *std::max_element(update_cpu_ms.begin(), update_cpu_ms.end());
  std::printf("\nsummary over %zu buildings, %zu keyframes (%dx%d, a keyframe every %.2f m, voxel 0.10 m, %s):\n",
              opt.seeds.size(), keyframes, opt.width, opt.height, opt.spacing_m, opt.odometry.describe().c_str());
  std::printf("  objects found: %.1f %% of %zu ground-truth objects (%.1f %% of the %zu observed)\n", found_pct, score.gt,
              found_observed_pct, score.observed);
  std::printf("  objects correct: %.1f %% of %zu estimated\n", correct_pct, score.estimated);
  std::printf("  (scored with the vertex mean instead of the reported position: found %.1f %%, correct %.1f %%)\n",
              pct(score.found_mean, score.gt), pct(score.correct_mean, score.estimated));
  std::printf("  frontend per update (objects, places, inter-layer edges): median %.3f ms, p99 %.3f ms, max %.3f ms\n", median, p99,
              max_ms);
  std::printf("  frontend per update, thread CPU time: median %.3f ms, p99 %.3f ms, max %.3f ms\n", cpu_median,
              cpu_p99, cpu_max);
  std::printf("  (reconstruction per keyframe, for scale: median %.2f ms)\n", quantile(recon_ms, 0.5));
  std::printf("  merges: centre-in-box %llu, intersecting boxes %llu, size prior %llu; merge search: %llu queries, "
              "%.1f objects tested per query\n",
              static_cast<unsigned long long>(score.merged_centre),
              static_cast<unsigned long long>(score.merged_intersect),
              static_cast<unsigned long long>(score.merged_size), static_cast<unsigned long long>(score.index_queries),
              score.index_queries == 0 ? 0.0 : static_cast<double>(score.index_visits) / score.index_queries);

  if (!opt.json_path.empty()) {
    std::string seeds;
    for (const std::uint64_t s : opt.seeds) seeds += (seeds.empty() ? "" : ",") + std::to_string(s);
    // At gt the wording the figures always had; with drifting odometry the level and seed.
    const std::string inputs = opt.odometry.ground_truth()
                                   ? "ground-truth poses depth and labels"
                                   : opt.odometry.describe() + ", ground-truth depth and labels";
    char cond[320];
    std::snprintf(cond, sizeof(cond),
                  "%zu buildings (%d rooms, seeds %s), %dx%d, keyframe every %.2f m, voxel 0.10 m, %s, %s budget, "
                  "one core",
                  opt.seeds.size(), opt.rooms, seeds.c_str(), opt.width, opt.height, opt.spacing_m, inputs.c_str(),
                  budgets::active::kBoard);
    bench::Figures figures(opt.settings.empty() ? std::string(cond) : std::string(cond) + ", set " + opt.settings);
    auto add = [&](const char* name, double value, const char* unit) { figures.add(name, value, unit); };
    add("objects_eval.found", found_pct, "%");
    add("objects_eval.found_of_observed", found_observed_pct, "%");
    add("objects_eval.correct", correct_pct, "%");
    add("objects_eval.ground_truth_objects", static_cast<double>(score.gt), "objects");
    add("objects_eval.estimated_objects", static_cast<double>(score.estimated), "objects");
    add("objects_eval.frontend_update_ms_median", median, "ms");
    add("objects_eval.frontend_update_ms_p99", p99, "ms");
    add("objects_eval.frontend_update_ms_max", max_ms, "ms");
    add("objects_eval.frontend_update_cpu_ms_median", cpu_median, "ms");
    add("objects_eval.frontend_update_cpu_ms_p99", cpu_p99, "ms");
    add("objects_eval.frontend_update_cpu_ms_max", cpu_max, "ms");
    add("objects_eval.keyframes", static_cast<double>(keyframes), "keyframes");
    add("objects_eval.merges_centre_in_box", static_cast<double>(score.merged_centre), "merges");
    add("objects_eval.merges_intersecting_boxes", static_cast<double>(score.merged_intersect), "merges");
    add("objects_eval.merges_size_prior", static_cast<double>(score.merged_size), "merges");
    add("objects_eval.merge_search_objects_per_query",
        score.index_queries == 0 ? 0.0 : static_cast<double>(score.index_visits) / score.index_queries, "objects");
    if (!figures.write(opt.json_path)) return 1;
  }
  return 0;
}
