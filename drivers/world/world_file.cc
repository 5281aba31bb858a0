// World file I/O: a line-per-element JSON writer and a validating reader that reports the JSON path of bad fields.
#include "drivers/world/world_file.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/json/json_guard.h"
#include "drivers/world/world_geometry.h"

namespace qsg::world {
namespace {

using json = nlohmann::ordered_json;
using semantics::Label;
using semantics::RoomLabel;

const char* texture_name(Texture t) {
  switch (t) {
    case Texture::kPlain: return "plain";
    case Texture::kChecker: return "checker";
    case Texture::kStripes: return "stripes";
    case Texture::kNoise: return "noise";
  }
  return "plain";
}

json vec(const Eigen::Vector2d& v) { return json::array({v.x(), v.y()}); }
json vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

json polygon_json(const Polygon2& poly) {
  json out = json::array();
  for (const Eigen::Vector2d& p : poly) out.push_back(vec(p));
  return out;
}

// "yaw" when the rotation is exactly a yaw about z that reproduces the same quaternion, else "rotation" [w,x,y,z].
void put_rotation(json& j, const Eigen::Quaterniond& q) {
  if (q.x() == 0.0 && q.y() == 0.0) {
    const double yaw = 2.0 * std::atan2(q.z(), q.w());
    const Eigen::Quaterniond back = yaw_rotation(yaw);
    if (back.w() == q.w() && back.x() == q.x() && back.y() == q.y() && back.z() == q.z()) {
      j["yaw"] = yaw;
      return;
    }
  }
  j["rotation"] = json::array({q.w(), q.x(), q.y(), q.z()});
}

json material_json(const Material& m) {
  json j;
  j["label"] = semantics::object_label(m.label).name;
  j["color"] = json::array({m.color[0], m.color[1], m.color[2]});
  j["texture"] = texture_name(m.texture);
  j["texture_scale"] = static_cast<double>(m.texture_scale_m);
  return j;
}

// ---- reader ----

std::string index_path(const std::string& path, std::size_t i) { return path + "[" + std::to_string(i) + "]"; }
std::string field_path(const std::string& path, const char* key) { return path.empty() ? key : path + "." + key; }

class Reader {
 public:
  std::string error;
  double max_abs_value = WorldFileLimits{}.max_abs_value_m;

  // Every number of the file is bounded before it is used, so no world can ask the renderer, the planner or the
  // ground truth for a grid or a bounding volume that overflows (2^31 m, 1e308 m).
  bool within_limit(double v, const std::string& path) {
    if (std::abs(v) <= max_abs_value) return true;
    char text[64];
    std::snprintf(text, sizeof(text), "%.10g", v);
    char limit[64];
    std::snprintf(limit, sizeof(limit), "%g", max_abs_value);
    return fail(path, std::string(text) + " is beyond the world file's limit of " + limit +
                          " (WorldFileLimits::max_abs_value_m: every coordinate and size, in metres)");
  }

  bool fail(const std::string& path, const std::string& message) {
    if (error.empty()) error = (path.empty() ? std::string("(top level)") : path) + ": " + message;
    return false;
  }

  // Checks j is an object holding only the allowed keys.
  bool object(const json& j, const std::string& path, std::initializer_list<const char*> allowed) {
    if (!j.is_object()) return fail(path, "expected an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
      bool known = false;
      for (const char* a : allowed) known = known || it.key() == a;
      if (!known) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
        return fail(field_path(path, it.key().c_str()), "unknown field (allowed: " + list + ")");
      }
    }
    return true;
  }

  const json* find(const json& j, const char* key) const {
    const auto it = j.find(key);
    return it == j.end() ? nullptr : &*it;
  }
  const json* require(const json& j, const std::string& path, const char* key) {
    const json* f = find(j, key);
    if (!f) fail(field_path(path, key), "missing required field");
    return f;
  }

  bool number(const json& j, const std::string& path, double* out) {
    if (!j.is_number()) return fail(path, "expected a number");
    *out = j.get<double>();
    if (!std::isfinite(*out)) return fail(path, "expected a finite number");
    return within_limit(*out, path);
  }
  bool number_field(const json& obj, const std::string& path, const char* key, double* out, bool required) {
    const json* f = required ? require(obj, path, key) : find(obj, key);
    if (!f) return !required;
    return number(*f, field_path(path, key), out);
  }
  bool positive_field(const json& obj, const std::string& path, const char* key, double* out, bool required) {
    if (!number_field(obj, path, key, out, required)) return false;
    if (!(*out > 0.0)) return fail(field_path(path, key), "must be positive");
    return true;
  }
  bool integer(const json& j, const std::string& path, long long lo, long long hi, long long* out) {
    if (!j.is_number_integer()) return fail(path, "expected an integer");
    *out = j.get<long long>();
    if (*out < lo || *out > hi)
      return fail(path, "must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return true;
  }
  bool int_field(const json& obj, const std::string& path, const char* key, long long lo, long long hi,
                 std::int32_t* out, bool required) {
    const json* f = required ? require(obj, path, key) : find(obj, key);
    if (!f) return !required;
    long long v = 0;
    if (!integer(*f, field_path(path, key), lo, hi, &v)) return false;
    *out = static_cast<std::int32_t>(v);
    return true;
  }
  bool vec2(const json& j, const std::string& path, Eigen::Vector2d* out) {
    if (!j.is_array() || j.size() != 2 || !j[0].is_number() || !j[1].is_number()) return fail(path, "expected [x, y]");
    *out = Eigen::Vector2d(j[0].get<double>(), j[1].get<double>());
    if (!out->allFinite()) return fail(path, "expected finite coordinates");
    for (int i = 0; i < 2; ++i)
      if (!within_limit((*out)[i], index_path(path, static_cast<std::size_t>(i)))) return false;
    return true;
  }
  bool vec3(const json& j, const std::string& path, Eigen::Vector3d* out) {
    if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number())
      return fail(path, "expected [x, y, z]");
    *out = Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
    if (!out->allFinite()) return fail(path, "expected finite coordinates");
    for (int i = 0; i < 3; ++i)
      if (!within_limit((*out)[i], index_path(path, static_cast<std::size_t>(i)))) return false;
    return true;
  }
  bool vec2_field(const json& obj, const std::string& path, const char* key, Eigen::Vector2d* out) {
    const json* f = require(obj, path, key);
    return f && vec2(*f, field_path(path, key), out);
  }
  bool vec3_field(const json& obj, const std::string& path, const char* key, Eigen::Vector3d* out) {
    const json* f = require(obj, path, key);
    return f && vec3(*f, field_path(path, key), out);
  }
  bool polygon(const json& j, const std::string& path, Polygon2* out) {
    if (!j.is_array()) return fail(path, "expected a polygon: [[x, y], [x, y], [x, y], ...]");
    out->clear();
    for (std::size_t i = 0; i < j.size(); ++i) {
      Eigen::Vector2d p;
      if (!vec2(j[i], index_path(path, i), &p)) return false;
      out->push_back(p);
    }
    if (out->size() < 3) return fail(path, "a polygon needs at least 3 points");
    return true;
  }
  bool array(const json& j, const std::string& path) {
    if (!j.is_array()) return fail(path, "expected an array");
    return true;
  }
  bool string(const json& j, const std::string& path, std::string* out) {
    if (!j.is_string()) return fail(path, "expected a string");
    *out = j.get<std::string>();
    return true;
  }
  bool object_label(const json& j, const std::string& path, Label* out) {
    std::string name;
    if (!string(j, path, &name)) return false;
    *out = semantics::object_label_from_name(name.c_str());
    if (*out == semantics::kInvalidLabel) {
      std::string known;
      for (Label l = 0; l < semantics::kNumObjectLabels; ++l)
        known += std::string(known.empty() ? "" : ", ") + semantics::object_label(l).name;
      return fail(path, "unknown object label '" + name + "' (known: " + known + ")");
    }
    return true;
  }
  bool room_label(const json& j, const std::string& path, RoomLabel* out) {
    std::string name;
    if (!string(j, path, &name)) return false;
    *out = semantics::room_label_from_name(name.c_str());
    if (*out == semantics::kInvalidLabel) {
      std::string known;
      for (RoomLabel l = 0; l < semantics::kNumRoomLabels; ++l)
        known += std::string(known.empty() ? "" : ", ") + semantics::room_label_name(l);
      return fail(path, "unknown room label '" + name + "' (known: " + known + ")");
    }
    return true;
  }
  bool rotation(const json& obj, const std::string& path, Eigen::Quaterniond* out) {
    const json* yaw = find(obj, "yaw");
    const json* rot = find(obj, "rotation");
    if (yaw && rot) return fail(field_path(path, "rotation"), "give either yaw or rotation, not both");
    *out = Eigen::Quaterniond::Identity();
    if (yaw) {
      double y = 0.0;
      if (!number(*yaw, field_path(path, "yaw"), &y)) return false;
      *out = yaw_rotation(y);
    } else if (rot) {
      const std::string p = field_path(path, "rotation");
      if (!rot->is_array() || rot->size() != 4) return fail(p, "expected [w, x, y, z]");
      double q[4];
      for (std::size_t i = 0; i < 4; ++i)
        if (!number((*rot)[i], index_path(p, i), &q[i])) return false;
      *out = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
      const double n = out->norm();
      if (!(n > 1e-9)) return fail(p, "quaternion must not be zero");
      if (std::abs(n - 1.0) > 1e-9) out->normalize();  // keeps unit input bit-exact
    }
    return true;
  }
  bool material(const json& j, const std::string& path, Material* out, bool label_required) {
    if (!object(j, path, {"label", "color", "texture", "texture_scale"})) return false;
    if (const json* l = label_required ? require(j, path, "label") : find(j, "label")) {
      if (!object_label(*l, field_path(path, "label"), &out->label)) return false;
    } else if (label_required) {
      return false;
    }
    if (const json* c = find(j, "color")) {
      const std::string p = field_path(path, "color");
      if (!c->is_array() || c->size() != 3) return fail(p, "expected [r, g, b] with integers 0-255");
      for (std::size_t i = 0; i < 3; ++i) {
        long long v = 0;
        if (!integer((*c)[i], index_path(p, i), 0, 255, &v)) return false;
        out->color[i] = static_cast<std::uint8_t>(v);
      }
    }
    if (const json* t = find(j, "texture")) {
      std::string name;
      if (!string(*t, field_path(path, "texture"), &name)) return false;
      if (name == "plain")
        out->texture = Texture::kPlain;
      else if (name == "checker")
        out->texture = Texture::kChecker;
      else if (name == "stripes")
        out->texture = Texture::kStripes;
      else if (name == "noise")
        out->texture = Texture::kNoise;
      else
        return fail(field_path(path, "texture"),
                    "unknown texture '" + name + "' (known: plain, checker, stripes, noise)");
    }
    double scale = out->texture_scale_m;
    if (!positive_field(j, path, "texture_scale", &scale, false)) return false;
    out->texture_scale_m = static_cast<float>(scale);
    return true;
  }
};

struct PendingWall {
  Eigen::Vector2d from, to;
  double thickness_m = 0.1, floor_z_m = 0.0, height_m = 2.5;
  std::int32_t room = -1;
  bool cut_doors = true;
  Material material;
};

bool parse_world(const json& root, Reader& rd, World& world) {
  if (!rd.object(root, "",
                 {"format", "version", "name", "walls", "wall_polygons", "rooms", "doors", "objects", "shapes"}))
    return false;
  if (const json* f = rd.find(root, "format")) {
    std::string s;
    if (!rd.string(*f, "format", &s)) return false;
    if (s != "qsg_world") return rd.fail("format", "expected \"qsg_world\", found \"" + s + "\"");
  }
  const json* version = rd.require(root, "", "version");
  if (!version) return false;
  long long v = 0;
  if (!rd.integer(*version, "version", 1, 1000000, &v)) return false;
  if (v != kWorldFileVersion)
    return rd.fail("version", "unsupported version " + std::to_string(v) + " (this reader knows " +
                                  std::to_string(kWorldFileVersion) + ")");
  if (const json* n = rd.find(root, "name"))
    if (!rd.string(*n, "name", &world.name)) return false;

  // Rooms.
  if (const json* rooms = rd.find(root, "rooms")) {
    if (!rd.array(*rooms, "rooms")) return false;
    for (std::size_t i = 0; i < rooms->size(); ++i) {
      const json& j = (*rooms)[i];
      const std::string p = index_path("rooms", i);
      if (!rd.object(j, p, {"id", "label", "footprint", "floor_z", "height", "floor_index"})) return false;
      Room r;
      r.id = static_cast<std::int32_t>(i);
      if (!rd.int_field(j, p, "id", 0, 1 << 30, &r.id, false)) return false;
      for (const Room& other : world.rooms)
        if (other.id == r.id) return rd.fail(field_path(p, "id"), "duplicate room id " + std::to_string(r.id));
      if (const json* l = rd.require(j, p, "label")) {
        if (!rd.room_label(*l, field_path(p, "label"), &r.label)) return false;
      } else {
        return false;
      }
      const json* fp = rd.require(j, p, "footprint");
      if (!fp) return false;
      const std::string fpp = field_path(p, "footprint");
      if (!fp->is_array() || fp->empty()) return rd.fail(fpp, "expected a list of polygons: [[[x, y], ...], ...]");
      for (std::size_t k = 0; k < fp->size(); ++k) {
        Polygon2 poly;
        if (!rd.polygon((*fp)[k], index_path(fpp, k), &poly)) return false;
        r.footprint_m.push_back(poly);
      }
      if (!rd.number_field(j, p, "floor_z", &r.floor_z_m, false)) return false;
      if (!rd.positive_field(j, p, "height", &r.height_m, false)) return false;
      if (!rd.int_field(j, p, "floor_index", -1000, 1000, &r.floor_index, false)) return false;
      world.rooms.push_back(r);
    }
  }
  auto room_exists = [&](std::int32_t id) {
    if (id == -1) return true;
    for (const Room& r : world.rooms)
      if (r.id == id) return true;
    return false;
  };
  auto room_ref = [&](const json& obj, const std::string& path, const char* key, std::int32_t* out) {
    if (!rd.int_field(obj, path, key, -1, 1 << 30, out, false)) return false;
    if (!room_exists(*out)) return rd.fail(field_path(path, key), "no room with id " + std::to_string(*out));
    return true;
  };

  // Doors.
  if (const json* doors = rd.find(root, "doors")) {
    if (!rd.array(*doors, "doors")) return false;
    for (std::size_t i = 0; i < doors->size(); ++i) {
      const json& j = (*doors)[i];
      const std::string p = index_path("doors", i);
      if (!rd.object(j, p, {"a", "b", "floor_z", "height", "room_a", "room_b"})) return false;
      Door d;
      if (!rd.vec2_field(j, p, "a", &d.a_m) || !rd.vec2_field(j, p, "b", &d.b_m)) return false;
      if (!rd.number_field(j, p, "floor_z", &d.floor_z_m, false)) return false;
      if (!rd.positive_field(j, p, "height", &d.height_m, false)) return false;
      if (!room_ref(j, p, "room_a", &d.room_a) || !room_ref(j, p, "room_b", &d.room_b)) return false;
      world.doors.push_back(d);
    }
  }

  // Objects (their shapes come later; they may refer to objects by index).
  std::vector<bool> object_box_shape;
  if (const json* objects = rd.find(root, "objects")) {
    if (!rd.array(*objects, "objects")) return false;
    for (std::size_t i = 0; i < objects->size(); ++i) {
      const json& j = (*objects)[i];
      const std::string p = index_path("objects", i);
      if (!rd.object(j, p, {"id", "label", "center", "size", "yaw", "rotation", "room", "add_box_shape"})) return false;
      Object o;
      o.id = static_cast<std::int32_t>(i);
      if (!rd.int_field(j, p, "id", 0, 1 << 30, &o.id, false)) return false;
      if (const json* l = rd.require(j, p, "label")) {
        if (!rd.object_label(*l, field_path(p, "label"), &o.label)) return false;
      } else {
        return false;
      }
      Eigen::Vector3d size;
      if (!rd.vec3_field(j, p, "center", &o.box.center_m) || !rd.vec3_field(j, p, "size", &size)) return false;
      if ((size.array() < 0.0).any()) return rd.fail(field_path(p, "size"), "sizes must not be negative");
      o.box.half_extents_m = 0.5 * size;
      if (!rd.rotation(j, p, &o.box.world_R_box)) return false;
      if (!room_ref(j, p, "room", &o.room_id)) return false;
      bool add_box = false;
      if (const json* a = rd.find(j, "add_box_shape")) {
        if (!a->is_boolean()) return rd.fail(field_path(p, "add_box_shape"), "expected true or false");
        add_box = a->get<bool>();
      }
      object_box_shape.push_back(add_box);
      world.objects.push_back(o);
    }
  }

  // Raw shapes, in order.
  if (const json* shapes = rd.find(root, "shapes")) {
    if (!rd.array(*shapes, "shapes")) return false;
    for (std::size_t i = 0; i < shapes->size(); ++i) {
      const json& j = (*shapes)[i];
      const std::string p = index_path("shapes", i);
      if (!j.is_object()) return rd.fail(p, "expected an object");
      const json* type = rd.require(j, p, "type");
      if (!type) return false;
      std::string kind;
      if (!rd.string(*type, field_path(p, "type"), &kind)) return false;
      Material m;
      std::int32_t object_id = -1, room_id = -1;
      auto common = [&](std::initializer_list<const char*> own) {
        std::vector<const char*> allowed(own);
        // object() takes an initializer_list, so check the union by hand.
        for (auto it = j.begin(); it != j.end(); ++it) {
          bool ok = it.key() == "type" || it.key() == "material" || it.key() == "object" || it.key() == "room";
          for (const char* a : allowed) ok = ok || it.key() == a;
          if (!ok) return rd.fail(field_path(p, it.key().c_str()), "unknown field for a " + kind);
        }
        const json* mat = rd.require(j, p, "material");
        if (!mat || !rd.material(*mat, field_path(p, "material"), &m, true)) return false;
        if (!rd.int_field(j, p, "object", -1, 1 << 30, &object_id, false)) return false;
        if (object_id >= static_cast<std::int32_t>(world.objects.size()))
          return rd.fail(field_path(p, "object"), "no object with index " + std::to_string(object_id));
        return room_ref(j, p, "room", &room_id);
      };
      if (kind == "box") {
        if (!common({"center", "size", "yaw", "rotation"})) return false;
        BoxShape b;
        Eigen::Vector3d size;
        if (!rd.vec3_field(j, p, "center", &b.center_m) || !rd.vec3_field(j, p, "size", &size)) return false;
        if ((size.array() < 0.0).any()) return rd.fail(field_path(p, "size"), "sizes must not be negative");
        b.half_extents_m = 0.5 * size;
        if (!rd.rotation(j, p, &b.world_R_box)) return false;
        world.add_box(b, m, object_id, room_id);
      } else if (kind == "cylinder") {
        if (!common({"base", "radius", "height"})) return false;
        CylinderShape c;
        if (!rd.vec3_field(j, p, "base", &c.base_center_m)) return false;
        if (!rd.positive_field(j, p, "radius", &c.radius_m, true)) return false;
        if (!rd.positive_field(j, p, "height", &c.height_m, true)) return false;
        world.add_cylinder(c, m, object_id, room_id);
      } else if (kind == "prism") {
        if (!common({"polygon", "z_min", "z_max"})) return false;
        PrismShape pr;
        const json* poly = rd.require(j, p, "polygon");
        if (!poly || !rd.polygon(*poly, field_path(p, "polygon"), &pr.polygon_m)) return false;
        if (!rd.number_field(j, p, "z_min", &pr.z_min_m, true) || !rd.number_field(j, p, "z_max", &pr.z_max_m, true))
          return false;
        if (pr.z_max_m <= pr.z_min_m) return rd.fail(field_path(p, "z_max"), "must exceed z_min");
        world.add_prism(pr, m, object_id, room_id);
      } else if (kind == "plane") {
        if (!common({"point", "normal"})) return false;
        if (object_id != -1 || room_id != -1)
          return rd.fail(p, "a plane belongs to no object or room (object and room must be -1)");
        PlaneShape pl;
        if (!rd.vec3_field(j, p, "point", &pl.point_m) || !rd.vec3_field(j, p, "normal", &pl.normal)) return false;
        if (!(pl.normal.norm() > 1e-9)) return rd.fail(field_path(p, "normal"), "must not be zero");
        world.add_plane(pl, m);
      } else {
        return rd.fail(field_path(p, "type"), "unknown shape type '" + kind + "' (known: box, cylinder, prism, plane)");
      }
    }
  }

  // Convenience walls, cut where a door lies along them.
  if (const json* walls = rd.find(root, "walls")) {
    if (!rd.array(*walls, "walls")) return false;
    for (std::size_t i = 0; i < walls->size(); ++i) {
      const json& j = (*walls)[i];
      const std::string p = index_path("walls", i);
      if (!rd.object(j, p, {"from", "to", "thickness", "floor_z", "height", "room", "material", "cut_doors"}))
        return false;
      PendingWall w;
      w.material.label = semantics::kWall;
      w.material.color = {{210, 205, 195}};
      if (!rd.vec2_field(j, p, "from", &w.from) || !rd.vec2_field(j, p, "to", &w.to)) return false;
      if ((w.to - w.from).norm() <= 1e-9) return rd.fail(field_path(p, "to"), "wall has zero length");
      if (!rd.positive_field(j, p, "thickness", &w.thickness_m, false)) return false;
      if (!rd.number_field(j, p, "floor_z", &w.floor_z_m, false)) return false;
      if (!rd.positive_field(j, p, "height", &w.height_m, false)) return false;
      if (!room_ref(j, p, "room", &w.room)) return false;
      if (const json* mat = rd.find(j, "material"))
        if (!rd.material(*mat, field_path(p, "material"), &w.material, false)) return false;
      if (const json* cut = rd.find(j, "cut_doors")) {
        if (!cut->is_boolean()) return rd.fail(field_path(p, "cut_doors"), "expected true or false");
        w.cut_doors = cut->get<bool>();
      }
      const double len = (w.to - w.from).norm();
      const Eigen::Vector2d dir = (w.to - w.from) / len, normal(-dir.y(), dir.x());
      std::vector<Interval> gaps;
      double gap_top = w.floor_z_m + w.height_m;
      if (w.cut_doors) {
        for (const Door& d : world.doors) {
          if (std::abs(d.floor_z_m - w.floor_z_m) > 1e-6) continue;
          const double tol = 0.5 * w.thickness_m + 0.01;
          if (std::abs((d.a_m - w.from).dot(normal)) > tol || std::abs((d.b_m - w.from).dot(normal)) > tol) continue;
          const double s0 = (d.a_m - w.from).dot(dir), s1 = (d.b_m - w.from).dot(dir);
          gaps.push_back({std::min(s0, s1), std::max(s0, s1)});
          gap_top = std::min(gap_top, w.floor_z_m + d.height_m);
        }
      }
      add_wall_with_gaps(world, w.from, w.to, w.thickness_m, 0.0, w.floor_z_m, w.floor_z_m + w.height_m, gaps, gap_top,
                         w.material, w.room);
    }
  }
  if (const json* polys = rd.find(root, "wall_polygons")) {
    if (!rd.array(*polys, "wall_polygons")) return false;
    for (std::size_t i = 0; i < polys->size(); ++i) {
      const json& j = (*polys)[i];
      const std::string p = index_path("wall_polygons", i);
      if (!rd.object(j, p, {"polygon", "floor_z", "height", "room", "material"})) return false;
      PrismShape pr;
      const json* poly = rd.require(j, p, "polygon");
      if (!poly || !rd.polygon(*poly, field_path(p, "polygon"), &pr.polygon_m)) return false;
      double floor_z = 0.0, height = 2.5;
      if (!rd.number_field(j, p, "floor_z", &floor_z, false)) return false;
      if (!rd.positive_field(j, p, "height", &height, false)) return false;
      pr.z_min_m = floor_z;
      pr.z_max_m = floor_z + height;
      std::int32_t room = -1;
      if (!room_ref(j, p, "room", &room)) return false;
      Material m;
      m.label = semantics::kWall;
      m.color = {{210, 205, 195}};
      if (const json* mat = rd.find(j, "material"))
        if (!rd.material(*mat, field_path(p, "material"), &m, false)) return false;
      world.add_prism(pr, m, -1, room);
    }
  }
  // Objects drawn as their own box.
  for (std::size_t i = 0; i < world.objects.size(); ++i) {
    if (!object_box_shape[i]) continue;
    const Object& o = world.objects[i];
    Material m;
    m.label = o.label;
    m.color = semantics::object_label(o.label).color;
    world.add_box(o.box, m, static_cast<std::int32_t>(i), o.room_id);
  }
  return true;
}

std::string compare_material(const Material& a, const Material& b) {
  if (a.label != b.label) return "label";
  if (a.color != b.color) return "color";
  if (a.texture != b.texture) return "texture";
  if (a.texture_scale_m != b.texture_scale_m) return "texture_scale";
  return {};
}

bool same_box(const BoxShape& a, const BoxShape& b) {
  return a.center_m == b.center_m && a.half_extents_m == b.half_extents_m &&
         a.world_R_box.coeffs() == b.world_R_box.coeffs();
}

bool same_polygon(const Polygon2& a, const Polygon2& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i] != b[i]) return false;
  return true;
}

}  // namespace

std::string world_to_json(const World& world) {
  // One element per line: readable and diff-friendly, unlike one number per line.
  std::ostringstream out;
  out << "{\n  \"format\": \"qsg_world\",\n  \"version\": " << kWorldFileVersion
      << ",\n  \"name\": " << json(world.name).dump(-1, ' ', false, json::error_handler_t::replace);
  auto section = [&](const char* key, const std::vector<json>& items) {
    out << ",\n  \"" << key << "\": [";
    for (std::size_t i = 0; i < items.size(); ++i)
      out << (i ? ",\n    " : "\n    ") << items[i].dump(-1, ' ', false, json::error_handler_t::replace);
    out << (items.empty() ? "]" : "\n  ]");
  };
  std::vector<json> items;
  for (const Room& r : world.rooms) {
    json j;
    j["id"] = r.id;
    j["label"] = semantics::room_label_name(r.label);
    json fp = json::array();
    for (const Polygon2& poly : r.footprint_m) fp.push_back(polygon_json(poly));
    j["footprint"] = fp;
    j["floor_z"] = r.floor_z_m;
    j["height"] = r.height_m;
    j["floor_index"] = r.floor_index;
    items.push_back(j);
  }
  section("rooms", items);
  items.clear();
  for (const Door& d : world.doors) {
    json j;
    j["a"] = vec(d.a_m);
    j["b"] = vec(d.b_m);
    j["floor_z"] = d.floor_z_m;
    j["height"] = d.height_m;
    j["room_a"] = d.room_a;
    j["room_b"] = d.room_b;
    items.push_back(j);
  }
  section("doors", items);
  items.clear();
  for (const Object& o : world.objects) {
    json j;
    j["id"] = o.id;
    j["label"] = semantics::object_label(o.label).name;
    j["center"] = vec(o.box.center_m);
    j["size"] = vec(Eigen::Vector3d(2.0 * o.box.half_extents_m));
    put_rotation(j, o.box.world_R_box);
    j["room"] = o.room_id;
    items.push_back(j);
  }
  section("objects", items);
  items.clear();
  for (const Shape& s : world.shapes) {
    json j;
    switch (s.kind) {
      case ShapeKind::kBox: {
        if (s.index >= world.boxes.size()) continue;
        const BoxShape& b = world.boxes[s.index];
        j["type"] = "box";
        j["center"] = vec(b.center_m);
        j["size"] = vec(Eigen::Vector3d(2.0 * b.half_extents_m));
        put_rotation(j, b.world_R_box);
        break;
      }
      case ShapeKind::kCylinder: {
        if (s.index >= world.cylinders.size()) continue;
        const CylinderShape& c = world.cylinders[s.index];
        j["type"] = "cylinder";
        j["base"] = vec(c.base_center_m);
        j["radius"] = c.radius_m;
        j["height"] = c.height_m;
        break;
      }
      case ShapeKind::kPrism: {
        if (s.index >= world.prisms.size()) continue;
        const PrismShape& p = world.prisms[s.index];
        j["type"] = "prism";
        j["polygon"] = polygon_json(p.polygon_m);
        j["z_min"] = p.z_min_m;
        j["z_max"] = p.z_max_m;
        break;
      }
      case ShapeKind::kPlane: {
        if (s.index >= world.planes.size()) continue;
        const PlaneShape& p = world.planes[s.index];
        j["type"] = "plane";
        j["point"] = vec(p.point_m);
        j["normal"] = vec(p.normal);
        break;
      }
    }
    j["material"] = material_json(s.material);
    j["object"] = s.object_id;
    j["room"] = s.room_id;
    items.push_back(j);
  }
  section("shapes", items);
  out << "\n}\n";
  return out.str();
}

bool write_world_file(const World& world, const std::string& path, std::string* error) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) {
    if (error) *error = path + ": cannot open for writing (" + std::strerror(errno) + ")";
    return false;
  }
  file << world_to_json(world);
  file.flush();
  if (!file) {
    if (error) *error = path + ": write failed (" + std::strerror(errno) + ")";
    return false;
  }
  return true;
}

WorldResult parse_world_json(const std::string& text, const std::string& source_name, const WorldFileLimits& limits) {
  WorldResult result;
  json root;
  // Line and column (1-based) of a byte offset into the text.
  auto position = [&](std::size_t offset) {
    offset = std::min(offset, text.size());
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; i < offset; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    return source_name + ":" + std::to_string(line) + ":" + std::to_string(column);
  };
  json_guard::ParseFailure failure;
  if (!json_guard::parse(text, json_guard::Limits{}, &root, &failure)) {
    using Kind = json_guard::ParseFailure::Kind;
    if (failure.kind == Kind::kSyntax && failure.byte != std::string::npos) {
      std::string detail = failure.message;
      const std::size_t at = detail.find("syntax error");
      if (at != std::string::npos) detail = detail.substr(at);
      result.error = position(failure.byte > 0 ? failure.byte - 1 : 0) + ": JSON " + detail;
    } else if (failure.kind == Kind::kNumberRange) {
      // Number overflow has no position; locate the quoted token the message names.
      const std::string& what = failure.message;
      const std::size_t q0 = what.find('\''), q1 = q0 == std::string::npos ? q0 : what.find('\'', q0 + 1);
      const std::size_t found = q1 == std::string::npos ? std::string::npos : text.find(what.substr(q0 + 1, q1 - q0 - 1));
      result.error = (found == std::string::npos ? source_name : position(found)) + ": cannot parse JSON: " + what;
    } else {
      result.error = source_name + ": " + failure.message;  // depth and duplicated keys name the path
    }
    return result;
  }
  Reader rd;
  rd.max_abs_value = limits.max_abs_value_m;
  bool ok = false;
  try {
    ok = parse_world(root, rd, result.world);
  } catch (const std::exception& e) {  // a reader bug must still not escape the API
    rd.fail("", std::string("internal error: ") + e.what());
  }
  if (!ok) {
    result.error = source_name + ": " + rd.error;
    result.world = World();
    return result;
  }
  result.ok = true;
  return result;
}

WorldResult read_world_file(const std::string& path, const WorldFileLimits& limits) {
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    WorldResult r;
    r.error = path + ": cannot open (" + std::strerror(errno) + ")";
    return r;
  }
  std::stringstream buffer;
  buffer << file.rdbuf();
  return parse_world_json(buffer.str(), path, limits);
}

bool worlds_equal(const World& a, const World& b, std::string* difference) {
  auto differ = [&](const std::string& what) {
    if (difference) *difference = what;
    return false;
  };
  if (a.name != b.name) return differ("name");
  if (a.shapes.size() != b.shapes.size()) return differ("shapes.size");
  if (a.boxes.size() != b.boxes.size() || a.cylinders.size() != b.cylinders.size() ||
      a.prisms.size() != b.prisms.size() || a.planes.size() != b.planes.size())
    return differ("primitive array sizes");
  for (std::size_t i = 0; i < a.shapes.size(); ++i) {
    const Shape &x = a.shapes[i], &y = b.shapes[i];
    const std::string p = "shapes[" + std::to_string(i) + "]";
    if (x.kind != y.kind || x.index != y.index) return differ(p + ".kind/index");
    if (x.object_id != y.object_id) return differ(p + ".object");
    if (x.room_id != y.room_id) return differ(p + ".room");
    const std::string m = compare_material(x.material, y.material);
    if (!m.empty()) return differ(p + ".material." + m);
  }
  for (std::size_t i = 0; i < a.boxes.size(); ++i)
    if (!same_box(a.boxes[i], b.boxes[i])) return differ("boxes[" + std::to_string(i) + "]");
  for (std::size_t i = 0; i < a.cylinders.size(); ++i) {
    const CylinderShape &x = a.cylinders[i], &y = b.cylinders[i];
    if (x.base_center_m != y.base_center_m || x.radius_m != y.radius_m || x.height_m != y.height_m)
      return differ("cylinders[" + std::to_string(i) + "]");
  }
  for (std::size_t i = 0; i < a.prisms.size(); ++i) {
    const PrismShape &x = a.prisms[i], &y = b.prisms[i];
    if (!same_polygon(x.polygon_m, y.polygon_m) || x.z_min_m != y.z_min_m || x.z_max_m != y.z_max_m)
      return differ("prisms[" + std::to_string(i) + "]");
  }
  for (std::size_t i = 0; i < a.planes.size(); ++i)
    if (a.planes[i].point_m != b.planes[i].point_m || a.planes[i].normal != b.planes[i].normal)
      return differ("planes[" + std::to_string(i) + "]");
  if (a.rooms.size() != b.rooms.size()) return differ("rooms.size");
  for (std::size_t i = 0; i < a.rooms.size(); ++i) {
    const Room &x = a.rooms[i], &y = b.rooms[i];
    const std::string p = "rooms[" + std::to_string(i) + "]";
    if (x.id != y.id || x.label != y.label || x.floor_z_m != y.floor_z_m || x.height_m != y.height_m ||
        x.floor_index != y.floor_index || x.footprint_m.size() != y.footprint_m.size())
      return differ(p);
    for (std::size_t k = 0; k < x.footprint_m.size(); ++k)
      if (!same_polygon(x.footprint_m[k], y.footprint_m[k])) return differ(p + ".footprint");
  }
  if (a.doors.size() != b.doors.size()) return differ("doors.size");
  for (std::size_t i = 0; i < a.doors.size(); ++i) {
    const Door &x = a.doors[i], &y = b.doors[i];
    if (x.a_m != y.a_m || x.b_m != y.b_m || x.floor_z_m != y.floor_z_m || x.height_m != y.height_m ||
        x.room_a != y.room_a || x.room_b != y.room_b)
      return differ("doors[" + std::to_string(i) + "]");
  }
  if (a.objects.size() != b.objects.size()) return differ("objects.size");
  for (std::size_t i = 0; i < a.objects.size(); ++i) {
    const Object &x = a.objects[i], &y = b.objects[i];
    if (x.id != y.id || x.label != y.label || x.room_id != y.room_id || !same_box(x.box, y.box))
      return differ("objects[" + std::to_string(i) + "]");
  }
  return true;
}

}  // namespace qsg::world
