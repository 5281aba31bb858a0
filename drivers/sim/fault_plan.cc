// Fault plans: parsing, scheduling, and the injecting decorators.
#include "drivers/sim/fault_plan.h"

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

namespace qsg::sim {
namespace {

constexpr const char* kKindNames[kNumFaultKinds] = {"drop",      "stall",      "late",
                                                    "backwards", "depth_nan",  "depth_zero",
                                                    "depth_saturated", "wrong_size", "unplug",
                                                    "dropout",   "pose_jump"};
// A read gives up (returns kTimeout) after this many consecutive dropped frames, so a drop rate of 1 on an
// endless source cannot spin forever.
constexpr int kMaxDropsPerRead = 64;

bool is_read_fault(FaultKind kind) { return kind == FaultKind::kStall || kind == FaultKind::kUnplug; }
bool has_samples(FaultKind kind) { return kind == FaultKind::kDropout || kind == FaultKind::kPoseJump; }
bool is_depth_fault(FaultKind kind) {
  return kind == FaultKind::kDepthNan || kind == FaultKind::kDepthZero || kind == FaultKind::kDepthSaturated;
}

std::string kind_list() {
  std::string names;
  for (int i = 0; i < kNumFaultKinds; ++i) names += std::string(i ? ", " : "") + kKindNames[i];
  return names;
}

std::string at_line(const std::string& origin, int line, const std::string& message) {
  return origin + ":" + std::to_string(line) + ": " + message;
}

bool parse_u64(const std::string& s, std::uint64_t* v) {
  if (s.empty() || s[0] == '-' || s[0] == '+') return false;
  char* end = nullptr;
  errno = 0;
  const unsigned long long x = std::strtoull(s.c_str(), &end, 10);
  if (end != s.c_str() + s.size() || errno == ERANGE) return false;
  *v = x;
  return true;
}

bool parse_positive_int(const std::string& s, int* v) {
  std::uint64_t x = 0;
  if (!parse_u64(s, &x) || x == 0 || x > 1'000'000'000u) return false;
  *v = static_cast<int>(x);
  return true;
}

bool parse_number(const std::string& s, double* v) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || errno == ERANGE || !std::isfinite(x)) return false;
  *v = x;
  return true;
}

bool parse_ms_to_ns(const std::string& s, std::int64_t* ns) {
  double ms = 0.0;
  if (!parse_number(s, &ms) || ms < 0.0 || ms > 1e9) return false;
  *ns = std::llround(ms * 1e6);
  return true;
}

// "x,y,w,h" with w, h > 0.
bool parse_rect(const std::string& s, PixelRect* rect) {
  int v[4];
  std::size_t pos = 0;
  for (int i = 0; i < 4; ++i) {
    const std::size_t comma = i < 3 ? s.find(',', pos) : s.size();
    if (comma == std::string::npos) return false;
    const std::string part = s.substr(pos, comma - pos);
    std::uint64_t x = 0;
    if (!parse_u64(part, &x) || x > 100000u) return false;
    v[i] = static_cast<int>(x);
    pos = comma + 1;
  }
  if (v[2] <= 0 || v[3] <= 0) return false;
  *rect = PixelRect{v[0], v[1], v[2], v[3]};
  return true;
}

// "WxH"
bool parse_size(const std::string& s, int* w, int* h) {
  const std::size_t x = s.find('x');
  if (x == std::string::npos) return false;
  return parse_positive_int(s.substr(0, x), w) && parse_positive_int(s.substr(x + 1), h);
}

// "x,y,z" in metres, each within +-1e4.
bool parse_offset(const std::string& s, double* v) {
  std::size_t pos = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = i < 2 ? s.find(',', pos) : s.size();
    if (comma == std::string::npos || !parse_number(s.substr(pos, comma - pos), &v[i]) || std::fabs(v[i]) > 1e4)
      return false;
    pos = comma + 1;
  }
  return true;
}

std::vector<std::vector<std::string>> split_lines(const std::string& text) {
  std::vector<std::vector<std::string>> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::vector<std::string> fields;
    std::string w;
    while (words >> w) fields.push_back(w);
    lines.push_back(std::move(fields));
  }
  return lines;
}

std::uint64_t splitmix64(std::uint64_t* state) {
  std::uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

void fill_depth(float* depth, int width, int height, const PixelRect& rect, float value) {
  const int x0 = std::max(0, rect.x_px);
  const int y0 = std::max(0, rect.y_px);
  const int x1 = std::min(width, rect.x_px + rect.width_px);
  const int y1 = std::min(height, rect.y_px + rect.height_px);
  for (int v = y0; v < y1; ++v) {
    for (int u = x0; u < x1; ++u) depth[static_cast<std::size_t>(v) * width + u] = value;
  }
}

// Sums the inner source's fault counts into the decorator's own.
drivers::DriverCounters merge(const drivers::DriverCounters& own, const drivers::DriverCounters& inner) {
  drivers::DriverCounters c;
  c.delivered = own.delivered;
  c.dropped = own.dropped + inner.dropped;
  c.stalls = own.stalls + inner.stalls;
  c.late = own.late + inner.late;
  c.timestamps_backwards = own.timestamps_backwards + inner.timestamps_backwards;
  c.invalid_depth_frames = own.invalid_depth_frames + inner.invalid_depth_frames;
  c.bad_frames = own.bad_frames + inner.bad_frames;
  c.disconnects = own.disconnects + inner.disconnects;
  c.reconnects = own.reconnects + inner.reconnects;
  c.missing_files = own.missing_files + inner.missing_files;
  return c;
}

}  // namespace

const char* to_string(FaultKind kind) {
  const int i = static_cast<int>(kind);
  return i >= 0 && i < kNumFaultKinds ? kKindNames[i] : "?";
}

bool fault_kind_from_string(const std::string& name, FaultKind* kind) {
  for (int i = 0; i < kNumFaultKinds; ++i) {
    if (name == kKindNames[i]) {
      *kind = static_cast<FaultKind>(i);
      return true;
    }
  }
  return false;
}

bool FaultPlan::has_random_faults() const {
  for (double r : random.rate) {
    if (r > 0.0) return true;
  }
  return false;
}

void FaultPlan::print(std::FILE* out) const {
  std::fprintf(out, "FaultPlan: %zu events, seed %" PRIu64 ", rates", events.size(), random.seed);
  for (int i = 0; i < kNumFaultKinds; ++i) std::fprintf(out, " %s=%g", kKindNames[i], random.rate[i]);
  std::fprintf(out,
               ", stall_reads=%d unplug_reads=%d delay_ns=%" PRId64 " back_ns=%" PRId64
               " region=%dx%d px dropout_samples=%d window=[%" PRIu64 ", %" PRIu64 ")\n",
               random.stall_reads, random.unplug_reads, random.delay_ns, random.back_ns, random.region_width_px,
               random.region_height_px, random.dropout_samples, random.from, random.until);
  for (const FaultEvent& e : events) {
    std::fprintf(out,
                 "  at %" PRIu64 " %s reads=%d delay_ns=%" PRId64 " back_ns=%" PRId64
                 " rect=%d,%d,%d,%d samples=%d offset_m=%g,%g,%g\n",
                 e.sequence, to_string(e.kind), e.reads, e.delay_ns, e.back_ns, e.rect.x_px, e.rect.y_px,
                 e.rect.width_px, e.rect.height_px, e.samples, e.offset_m[0], e.offset_m[1], e.offset_m[2]);
  }
}

bool parse_fault_plan_text(const std::string& text, const std::string& origin, FaultPlan* plan, std::string* error) {
  FaultPlan result;
  const auto lines = split_lines(text);
  for (std::size_t li = 0; li < lines.size(); ++li) {
    const std::vector<std::string>& f = lines[li];
    const int line = static_cast<int>(li) + 1;
    const auto fail = [&](const std::string& message) {
      if (error) *error = at_line(origin, line, message);
      return false;
    };
    if (f.empty()) continue;
    if (f[0] == "seed") {
      if (f.size() != 2 || !parse_u64(f[1], &result.random.seed)) return fail("expected 'seed <unsigned integer>'");
    } else if (f[0] == "rate") {
      FaultKind kind;
      double p = 0.0;
      if (f.size() != 3) return fail("expected 'rate <fault> <probability>'");
      if (!fault_kind_from_string(f[1], &kind)) return fail("unknown fault '" + f[1] + "' (expected " + kind_list() + ")");
      if (kind == FaultKind::kPoseJump) return fail("pose_jump has no random rate (script it with 'at')");
      if (!parse_number(f[2], &p) || p < 0.0 || p > 1.0) return fail("probability '" + f[2] + "' is not in [0, 1]");
      result.random.rate[static_cast<int>(kind)] = p;
    } else if (f[0] == "random") {
      if (f.size() < 2) return fail("expected 'random key=value ...'");
      for (std::size_t i = 1; i < f.size(); ++i) {
        const std::size_t eq = f[i].find('=');
        const std::string key = f[i].substr(0, eq);
        const std::string value = eq == std::string::npos ? std::string() : f[i].substr(eq + 1);
        bool ok = false;
        if (key == "stall_reads") ok = parse_positive_int(value, &result.random.stall_reads);
        else if (key == "unplug_reads") ok = parse_positive_int(value, &result.random.unplug_reads);
        else if (key == "delay_ms") ok = parse_ms_to_ns(value, &result.random.delay_ns);
        else if (key == "back_ms") ok = parse_ms_to_ns(value, &result.random.back_ns);
        else if (key == "region") ok = parse_size(value, &result.random.region_width_px, &result.random.region_height_px);
        else if (key == "dropout_samples") ok = parse_positive_int(value, &result.random.dropout_samples);
        else if (key == "from") ok = parse_u64(value, &result.random.from);
        else if (key == "until") ok = parse_u64(value, &result.random.until);
        else
          return fail("unknown key '" + key +
                      "' (expected stall_reads, unplug_reads, delay_ms, back_ms, region, dropout_samples, from, until)");
        if (!ok) return fail("bad value '" + value + "' for '" + key + "'");
      }
    } else if (f[0] == "at") {
      FaultEvent e;
      e.line_number = line;
      if (f.size() < 3) return fail("expected 'at <sequence> <fault> [key=value ...]'");
      if (!parse_u64(f[1], &e.sequence)) return fail("sequence '" + f[1] + "' is not an unsigned integer");
      if (!fault_kind_from_string(f[2], &e.kind)) return fail("unknown fault '" + f[2] + "' (expected " + kind_list() + ")");
      bool have_rect = false;
      bool have_offset = false;
      for (std::size_t i = 3; i < f.size(); ++i) {
        const std::size_t eq = f[i].find('=');
        const std::string key = f[i].substr(0, eq);
        const std::string value = eq == std::string::npos ? std::string() : f[i].substr(eq + 1);
        bool ok = false;
        bool applies = false;
        if (key == "reads") {
          applies = is_read_fault(e.kind);
          ok = parse_positive_int(value, &e.reads);
        } else if (key == "delay_ms") {
          applies = e.kind == FaultKind::kLate;
          ok = parse_ms_to_ns(value, &e.delay_ns);
        } else if (key == "back_ms") {
          applies = e.kind == FaultKind::kTimestampBackwards;
          ok = parse_ms_to_ns(value, &e.back_ns);
        } else if (key == "rect") {
          applies = is_depth_fault(e.kind);
          ok = parse_rect(value, &e.rect);
          have_rect = true;
        } else if (key == "samples") {
          applies = has_samples(e.kind);
          ok = parse_positive_int(value, &e.samples);
        } else if (key == "offset_m") {
          applies = e.kind == FaultKind::kPoseJump;
          ok = parse_offset(value, e.offset_m);
          have_offset = true;
        } else {
          return fail("unknown key '" + key + "' (expected reads, delay_ms, back_ms, rect, samples, offset_m)");
        }
        if (!applies) return fail("'" + key + "' does not apply to fault '" + f[2] + "'");
        if (!ok) return fail("bad value '" + value + "' for '" + key + "'");
      }
      if (is_depth_fault(e.kind) && !have_rect) return fail("fault '" + f[2] + "' needs rect=x,y,width,height");
      if (e.kind == FaultKind::kPoseJump && !have_offset) return fail("fault 'pose_jump' needs offset_m=x,y,z");
      result.events.push_back(e);
    } else {
      return fail("unknown directive '" + f[0] + "' (expected seed, rate, random, at)");
    }
  }
  *plan = std::move(result);
  return true;
}

bool parse_fault_plan_json(const std::string& text, const std::string& origin, FaultPlan* plan, std::string* error) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    if (error) *error = origin + ": " + e.what();
    return false;
  }
  const auto fail = [&](const std::string& field, const std::string& message) {
    if (error) *error = origin + ": " + field + ": " + message;
    return false;
  };
  if (!doc.is_object()) return fail("(top level)", "expected an object");
  FaultPlan result;
  const auto get_positive_int = [&](const nlohmann::json& j, const std::string& field, int* v) {
    if (!j.is_number_integer() || j.get<std::int64_t>() <= 0 || j.get<std::int64_t>() > 1'000'000'000) {
      return fail(field, "expected a positive integer");
    }
    *v = j.get<int>();
    return true;
  };
  const auto get_ms = [&](const nlohmann::json& j, const std::string& field, std::int64_t* ns) {
    if (!j.is_number() || j.get<double>() < 0.0 || j.get<double>() > 1e9) {
      return fail(field, "expected a non-negative number of milliseconds");
    }
    *ns = std::llround(j.get<double>() * 1e6);
    return true;
  };
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    const std::string& key = it.key();
    const nlohmann::json& v = it.value();
    if (key == "seed") {
      if (!v.is_number_unsigned()) return fail("seed", "expected an unsigned integer");
      result.random.seed = v.get<std::uint64_t>();
    } else if (key == "rates") {
      if (!v.is_object()) return fail("rates", "expected an object of fault: probability");
      for (auto r = v.begin(); r != v.end(); ++r) {
        FaultKind kind;
        if (!fault_kind_from_string(r.key(), &kind)) {
          return fail("rates." + r.key(), "unknown fault (expected " + kind_list() + ")");
        }
        if (kind == FaultKind::kPoseJump) return fail("rates.pose_jump", "no random rate (script it in events)");
        if (!r.value().is_number() || r.value().get<double>() < 0.0 || r.value().get<double>() > 1.0) {
          return fail("rates." + r.key(), "expected a probability in [0, 1]");
        }
        result.random.rate[static_cast<int>(kind)] = r.value().get<double>();
      }
    } else if (key == "random") {
      if (!v.is_object()) return fail("random", "expected an object");
      for (auto r = v.begin(); r != v.end(); ++r) {
        const std::string field = "random." + r.key();
        bool ok = true;
        if (r.key() == "stall_reads") ok = get_positive_int(r.value(), field, &result.random.stall_reads);
        else if (r.key() == "unplug_reads") ok = get_positive_int(r.value(), field, &result.random.unplug_reads);
        else if (r.key() == "delay_ms") ok = get_ms(r.value(), field, &result.random.delay_ns);
        else if (r.key() == "back_ms") ok = get_ms(r.value(), field, &result.random.back_ns);
        else if (r.key() == "region") {
          if (!r.value().is_array() || r.value().size() != 2) return fail(field, "expected [width, height]");
          ok = get_positive_int(r.value()[0], field + "[0]", &result.random.region_width_px) &&
               get_positive_int(r.value()[1], field + "[1]", &result.random.region_height_px);
        } else if (r.key() == "dropout_samples") {
          ok = get_positive_int(r.value(), field, &result.random.dropout_samples);
        } else if (r.key() == "from" || r.key() == "until") {
          if (!r.value().is_number_unsigned()) return fail(field, "expected an unsigned integer sequence number");
          (r.key() == "from" ? result.random.from : result.random.until) = r.value().get<std::uint64_t>();
        } else {
          return fail(field, "unknown key (expected stall_reads, unplug_reads, delay_ms, back_ms, region, "
                             "dropout_samples, from, until)");
        }
        if (!ok) return false;
      }
    } else if (key == "events") {
      if (!v.is_array()) return fail("events", "expected an array");
      for (std::size_t i = 0; i < v.size(); ++i) {
        const std::string prefix = "events[" + std::to_string(i) + "]";
        const nlohmann::json& ej = v[i];
        if (!ej.is_object()) return fail(prefix, "expected an object");
        FaultEvent e;
        if (!ej.contains("at") || !ej["at"].is_number_unsigned()) {
          return fail(prefix + ".at", "expected an unsigned integer sequence number");
        }
        e.sequence = ej["at"].get<std::uint64_t>();
        if (!ej.contains("fault") || !ej["fault"].is_string() ||
            !fault_kind_from_string(ej["fault"].get<std::string>(), &e.kind)) {
          return fail(prefix + ".fault", "expected one of " + kind_list());
        }
        bool have_rect = false;
        bool have_offset = false;
        for (auto f = ej.begin(); f != ej.end(); ++f) {
          const std::string field = prefix + "." + f.key();
          bool ok = true;
          bool applies = true;
          if (f.key() == "at" || f.key() == "fault") continue;
          if (f.key() == "reads") {
            applies = is_read_fault(e.kind);
            ok = applies && get_positive_int(f.value(), field, &e.reads);
          } else if (f.key() == "delay_ms") {
            applies = e.kind == FaultKind::kLate;
            ok = applies && get_ms(f.value(), field, &e.delay_ns);
          } else if (f.key() == "back_ms") {
            applies = e.kind == FaultKind::kTimestampBackwards;
            ok = applies && get_ms(f.value(), field, &e.back_ns);
          } else if (f.key() == "rect") {
            applies = is_depth_fault(e.kind);
            have_rect = true;
            if (applies) {
              const nlohmann::json& r = f.value();
              bool valid = r.is_array() && r.size() == 4;
              for (std::size_t k = 0; valid && k < 4; ++k) {
                valid = r[k].is_number_integer() && r[k].get<std::int64_t>() >= 0 && r[k].get<std::int64_t>() <= 100000;
              }
              if (!valid || r[2].get<int>() <= 0 || r[3].get<int>() <= 0) {
                return fail(field, "expected [x, y, width, height] in pixels, width and height > 0");
              }
              e.rect = PixelRect{r[0].get<int>(), r[1].get<int>(), r[2].get<int>(), r[3].get<int>()};
            }
          } else if (f.key() == "samples") {
            applies = has_samples(e.kind);
            ok = applies && get_positive_int(f.value(), field, &e.samples);
          } else if (f.key() == "offset_m") {
            applies = e.kind == FaultKind::kPoseJump;
            have_offset = true;
            if (applies) {
              const nlohmann::json& o = f.value();
              bool valid = o.is_array() && o.size() == 3;
              for (std::size_t k = 0; valid && k < 3; ++k)
                valid = o[k].is_number() && std::fabs(o[k].get<double>()) <= 1e4;
              if (!valid) return fail(field, "expected [x, y, z] in metres, each within +-1e4");
              for (int k = 0; k < 3; ++k) e.offset_m[k] = o[static_cast<std::size_t>(k)].get<double>();
            }
          } else {
            return fail(field, "unknown key (expected at, fault, reads, delay_ms, back_ms, rect, samples, offset_m)");
          }
          if (!applies) return fail(field, "does not apply to fault '" + std::string(to_string(e.kind)) + "'");
          if (!ok) return false;
        }
        if (is_depth_fault(e.kind) && !have_rect) return fail(prefix + ".rect", "required for depth faults");
        if (e.kind == FaultKind::kPoseJump && !have_offset) return fail(prefix + ".offset_m", "required for pose_jump");
        result.events.push_back(e);
      }
    } else {
      return fail(key, "unknown key (expected seed, rates, random, events)");
    }
  }
  *plan = std::move(result);
  return true;
}

bool load_fault_plan(const std::string& path, FaultPlan* plan, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (error) *error = path + ": cannot open";
    return false;
  }
  std::ostringstream text;
  text << in.rdbuf();
  const bool json = path.size() >= 5 && path.compare(path.size() - 5, 5, ".json") == 0;
  return json ? parse_fault_plan_json(text.str(), path, plan, error)
              : parse_fault_plan_text(text.str(), path, plan, error);
}

// ---------------------------------------------------------------------------------------------------------------

FaultScheduler::FaultScheduler(const FaultPlan& plan) : random_(plan.random) {
  for (const FaultEvent& e : plan.events) (is_read_fault(e.kind) ? read_events_ : frame_events_).push_back(e);
  const auto by_sequence = [](const FaultEvent& a, const FaultEvent& b) { return a.sequence < b.sequence; };
  std::stable_sort(read_events_.begin(), read_events_.end(), by_sequence);
  std::stable_sort(frame_events_.begin(), frame_events_.end(), by_sequence);
  random_enabled_ = plan.has_random_faults();
  rng_state_ = random_.seed;
}

double FaultScheduler::uniform() { return static_cast<double>(splitmix64(&rng_state_) >> 11) * 0x1.0p-53; }

bool FaultScheduler::fires(FaultKind kind) {
  const double rate = random_.rate[static_cast<int>(kind)];
  return rate > 0.0 && uniform() < rate;
}

drivers::ReadStatus FaultScheduler::before_read() {
  if (pending_timeouts_ == 0 && pending_disconnects_ == 0) {
    while (read_cursor_ < read_events_.size() && read_events_[read_cursor_].sequence <= next_expected_) {
      const FaultEvent& e = read_events_[read_cursor_++];
      if (e.kind == FaultKind::kStall) {
        pending_timeouts_ += e.reads;
        ++tally_[static_cast<int>(FaultKind::kStall)];
      } else {
        pending_disconnects_ += e.reads;
        ++disconnects_;
        ++tally_[static_cast<int>(FaultKind::kUnplug)];
      }
    }
    if (random_enabled_ && !slot_drawn_ && in_window(next_expected_)) {
      slot_drawn_ = true;
      if (fires(FaultKind::kStall)) {
        pending_timeouts_ += random_.stall_reads;
        ++tally_[static_cast<int>(FaultKind::kStall)];
      }
      if (fires(FaultKind::kUnplug)) {
        pending_disconnects_ += random_.unplug_reads;
        ++disconnects_;
        ++tally_[static_cast<int>(FaultKind::kUnplug)];
      }
    }
  }
  if (pending_timeouts_ > 0) {
    --pending_timeouts_;
    return drivers::ReadStatus::kTimeout;
  }
  if (pending_disconnects_ > 0) {
    if (--pending_disconnects_ == 0) reconnect_pending_ = true;
    return drivers::ReadStatus::kDisconnected;
  }
  return drivers::ReadStatus::kOk;
}

FaultScheduler::FrameFaults FaultScheduler::on_frame(std::uint64_t sequence, bool has_depth, int width_px,
                                                     int height_px) {
  FrameFaults faults;
  next_expected_ = sequence + 1;
  slot_drawn_ = false;
  const auto apply = [&](FaultKind kind, std::int64_t delay_ns, std::int64_t back_ns, const PixelRect& rect) {
    ++tally_[static_cast<int>(kind)];
    switch (kind) {
      case FaultKind::kDrop: faults.drop = true; break;
      case FaultKind::kWrongSize: faults.wrong_size = true; break;
      case FaultKind::kLate: faults.late_ns += delay_ns; break;
      case FaultKind::kTimestampBackwards: faults.back_ns = std::max(faults.back_ns, back_ns); break;
      case FaultKind::kDepthNan:
      case FaultKind::kDepthZero:
      case FaultKind::kDepthSaturated:
        faults.depth = true;
        faults.depth_kind = kind;
        faults.rect = rect;
        break;
      case FaultKind::kDropout:
      case FaultKind::kPoseJump:
      case FaultKind::kStall:
      case FaultKind::kUnplug: break;
    }
  };
  while (frame_cursor_ < frame_events_.size() && frame_events_[frame_cursor_].sequence <= sequence) {
    const FaultEvent& e = frame_events_[frame_cursor_++];
    if ((is_depth_fault(e.kind) && !has_depth) || (e.kind == FaultKind::kPoseJump && has_depth)) continue;
    if (e.kind == FaultKind::kDropout) {
      ++tally_[static_cast<int>(FaultKind::kDropout)];
      pending_dropout_ = std::max(pending_dropout_, e.samples);
    } else if (e.kind == FaultKind::kPoseJump) {
      ++tally_[static_cast<int>(FaultKind::kPoseJump)];
      pending_jump_ = e.samples;
      for (int i = 0; i < 3; ++i) jump_m_[i] = e.offset_m[i];
    } else {
      apply(e.kind, e.delay_ns, e.back_ns, e.rect);
    }
  }
  if (random_enabled_ && in_window(sequence)) {
    for (int k = 0; k < kNumFaultKinds; ++k) {
      const FaultKind kind = static_cast<FaultKind>(k);
      if (is_read_fault(kind) || kind == FaultKind::kPoseJump || (is_depth_fault(kind) && !has_depth) || !fires(kind))
        continue;
      if (kind == FaultKind::kDropout) {
        ++tally_[k];
        pending_dropout_ = std::max(pending_dropout_, random_.dropout_samples);
        continue;
      }
      PixelRect rect;
      if (is_depth_fault(kind)) {
        rect.width_px = std::min(random_.region_width_px, std::max(width_px, 1));
        rect.height_px = std::min(random_.region_height_px, std::max(height_px, 1));
        rect.x_px = static_cast<int>(uniform() * (std::max(width_px - rect.width_px, 0) + 1));
        rect.y_px = static_cast<int>(uniform() * (std::max(height_px - rect.height_px, 0) + 1));
      }
      apply(kind, random_.delay_ns, random_.back_ns, rect);
    }
  }
  if (pending_dropout_ > 0) {
    --pending_dropout_;
    faults.drop = true;
  }
  if (pending_jump_ > 0) {
    --pending_jump_;
    faults.jump = true;
    for (int i = 0; i < 3; ++i) faults.jump_m[i] = jump_m_[i];
  }
  return faults;
}

bool FaultScheduler::take_reconnect() {
  const bool r = reconnect_pending_;
  reconnect_pending_ = false;
  return r;
}

// ---------------------------------------------------------------------------------------------------------------

void FaultInjector::refresh(const drivers::DriverCounters& inner) {
  own_.disconnects = scheduler_.disconnects();
  counters_ = merge(own_, inner);
}

drivers::ReadStatus FaultInjector::finish(drivers::ReadStatus status, const drivers::DriverCounters& inner) {
  refresh(inner);
  return status;
}

// What the scheduler needs to place random depth faults: frames have depth of their own size, odometry none.
struct DepthShape {
  bool has_depth;
  int width;
  int height;
};
DepthShape depth_shape(const messages::RgbdFrame& f) { return {true, f.width(), f.height()}; }
DepthShape depth_shape(const messages::OdometrySample&) { return {false, 0, 0}; }

template <typename Source, typename Message, typename Extra>
drivers::ReadStatus FaultInjector::read(Source& inner, Message& message, std::int64_t timeout_ns, Extra&& apply_extra) {
  for (int attempt = 0; attempt < kMaxDropsPerRead; ++attempt) {
    const drivers::ReadStatus before = scheduler_.before_read();
    if (before != drivers::ReadStatus::kOk) {
      fault_open_ = true;
      if (before == drivers::ReadStatus::kTimeout) ++own_.stalls;
      return finish(before, inner.counters());
    }
    const drivers::ReadStatus status = inner.read(message, timeout_ns);
    if (status != drivers::ReadStatus::kOk) return finish(status, inner.counters());
    const DepthShape shape = depth_shape(message);
    const FaultScheduler::FrameFaults faults =
        scheduler_.on_frame(message.sequence, shape.has_depth, shape.width, shape.height);
    if (faults.any()) fault_open_ = true;
    if (faults.drop) {
      ++own_.dropped;
      gap_pending_ = true;
      continue;
    }
    if (faults.wrong_size) {
      ++own_.bad_frames;
      gap_pending_ = true;
      return finish(drivers::ReadStatus::kBadFrame, inner.counters());
    }
    if (faults.late_ns > 0) {
      message.publish_time_ns += faults.late_ns;
      message.flags |= messages::kFrameLate;
      ++own_.late;
    }
    if (faults.back_ns > 0) {
      const std::int64_t reference = have_last_ ? last_sample_time_ns_ : message.sample_time_ns;
      message.sample_time_ns = std::min(message.sample_time_ns, reference - faults.back_ns);
      message.flags |= messages::kFrameTimestampBackwards;
      ++own_.timestamps_backwards;
    }
    apply_extra(message, faults, own_);
    if (gap_pending_ || (have_last_ && message.sequence != last_sequence_ + 1)) {
      message.flags |= messages::kFrameSequenceGap;
    }
    if (scheduler_.take_reconnect()) {
      message.flags |= messages::kFrameAfterReconnect;
      ++own_.reconnects;
    }
    if (!faults.any() && fault_open_) {
      fault_open_ = false;
      ++faults_ended_;
      last_fault_end_ns_ = message.sample_time_ns;
    }
    gap_pending_ = false;
    have_last_ = true;
    last_sequence_ = message.sequence;
    last_sample_time_ns_ = message.sample_time_ns;
    ++own_.delivered;
    return finish(drivers::ReadStatus::kOk, inner.counters());
  }
  ++own_.stalls;  // every frame this read saw was dropped: to the consumer, nothing arrived in time
  return finish(drivers::ReadStatus::kTimeout, inner.counters());
}

FaultInjectingRgbdSource::FaultInjectingRgbdSource(drivers::RgbdSource& inner, const FaultPlan& plan)
    : inner_(inner), injector_(plan) {
  injector_.refresh(inner_.counters());
}

drivers::ReadStatus FaultInjectingRgbdSource::read(messages::RgbdFrame& frame, std::int64_t timeout_ns) {
  return injector_.read(inner_, frame, timeout_ns,
                        [](messages::RgbdFrame& f, const FaultScheduler::FrameFaults& faults,
                           drivers::DriverCounters& own) {
                          if (!faults.depth) return;
                          const float value = faults.depth_kind == FaultKind::kDepthNan
                                                  ? std::numeric_limits<float>::quiet_NaN()
                                              : faults.depth_kind == FaultKind::kDepthZero ? 0.0f
                                                                                           : 65535.0f * f.depth_scale_m;
                          fill_depth(f.depth_m.data(), f.width(), f.height(), faults.rect, value);
                          f.flags |= messages::kFrameInvalidDepthRegion;
                          ++own.invalid_depth_frames;
                        });
}

FaultInjectingOdometrySource::FaultInjectingOdometrySource(drivers::OdometrySource& inner, const FaultPlan& plan)
    : inner_(inner), injector_(plan) {
  injector_.refresh(inner_.counters());
}

drivers::ReadStatus FaultInjectingOdometrySource::read(messages::OdometrySample& sample, std::int64_t timeout_ns) {
  return injector_.read(inner_, sample, timeout_ns,
                        [](messages::OdometrySample& s, const FaultScheduler::FrameFaults& faults,
                           drivers::DriverCounters&) {
                          if (faults.jump) s.world_t_body_m += Eigen::Vector3d(faults.jump_m[0], faults.jump_m[1], faults.jump_m[2]);
                        });
}

}  // namespace qsg::sim
