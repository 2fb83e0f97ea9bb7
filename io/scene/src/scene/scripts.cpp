// The readers of what moves or holds an object: objects[i].motion (and a pin group's), animation
// (an OBJ sequence), keyframes and pins.
#include <Eigen/Geometry>
#include <cctype>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>

#include "../scene_schema.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/obj.hpp"
#include "input.hpp"

namespace ccfr::io::scene {

namespace {

/// `pattern` with its one %d / %0Nd field replaced by `number`; nullopt unless it has exactly one.
std::optional<std::string> sequence_name(const std::string& pattern, long number) {
  std::string out;
  int fields = 0;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') {
      out += pattern[i];
      continue;
    }
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      out += '%';
      ++i;
      continue;
    }
    size_t j = i + 1;
    const bool zero = j < pattern.size() && pattern[j] == '0';
    size_t width = 0;
    while (j < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[j])) && width < 100)
      width = width * 10 + static_cast<size_t>(pattern[j++] - '0');
    if (j >= pattern.size() || pattern[j] != 'd' || ++fields > 1) return std::nullopt;
    std::string n = std::to_string(number);
    if (n.size() < width) n.insert(0, width - n.size(), zero ? '0' : ' ');
    out += n;
    i = j;
  }
  if (fields != 1) return std::nullopt;
  return out;
}

}  // namespace

Motion read_motion(const YAML::Node& m) {
  Motion mo;
  if (m) motion_section().read(mo, m);
  return mo;
}

void check_motion(const Input& in, const YAML::Node& m, const std::string& mpath) {
  if (!m) return;
  if (m["end"].as<double>() < m["start"].as<double>())
    in.ctx.fail(mpath + ".end", in.in_node(mpath + ".end"),
                "the motion ends (" + m["end"].as<std::string>() + " s) before it starts (" +
                    m["start"].as<std::string>() + " s)",
                {mpath + ".start"});
  if (v3(m["axis"]).norm() == 0.0 && m["angular_velocity"].as<double>() != 0.0)
    in.ctx.fail(mpath + ".axis", in.in_node(mpath + ".axis"),
                "axis [0, 0, 0] has no direction, but angular_velocity is " + m["angular_velocity"].as<std::string>(),
                {mpath + ".angular_velocity"});
}

/// An obstacle animated by an OBJ sequence: every file read, placed by `transform` and checked
/// against the object's vertex count; the object starts at the first file.
void read_animation(const Input& in, const YAML::Node& o, const ObjectInfo& info, SimState& st, ObjectParams& op,
                    const std::string& path) {
  const YAML::Node a = o["animation"];
  const std::string apath = path + ".animation";
  if (info.kind != ObjectKind::obstacle)
    in.ctx.fail(apath, in.in_node(apath), "only obstacles can be animated by a sequence", {path + ".kind"});
  if (op.motion.moves())
    in.ctx.fail(apath, in.in_node(apath), "an object has either `motion` or `animation`, not both", {path + ".motion"});
  const std::string pattern = a["path"].as<std::string>();
  const double fps = a["fps"].as<double>() > 0 ? a["fps"].as<double>() : in.cfg["time"]["fps"].as<double>();
  auto anim = std::make_shared<VertexAnimation>();
  for (long k = 0; k < a["count"].as<long>(); ++k) {
    const long number = a["first"].as<long>() + k;
    const std::optional<std::string> name = sequence_name(pattern, number);
    if (!name)
      in.ctx.fail(apath + ".path", in.in_node(apath + ".path"),
                  "'" + pattern + "' needs exactly one integer field such as %d or %03d (and %% for a percent sign)");
    fs::path file = *name;
    if (file.is_relative()) file = in.base / file;
    RawGeometry g;
    try {
      g.v = read_obj_mesh(file).v;
    } catch (const Error& e) {
      in.ctx.fail(apath + ".path", in.in_node(apath + ".path"), "file " + std::to_string(number) + ": " + e.what());
    }
    if (static_cast<Index>(g.v.size()) != info.num_vertices())
      in.ctx.fail(apath + ".path", in.in_node(apath + ".path"),
                  "'" + file.string() + "' has " + std::to_string(g.v.size()) + " vertices, the object " +
                      std::to_string(info.num_vertices()));
    place(g, o["transform"]);
    check_placed(in, g.v, apath + ".path", info.name + "' (file " + std::to_string(number) + ")");
    anim->times.push_back(static_cast<double>(k) / fps);
    anim->keys.push_back(std::move(g.v));
  }
  for (Index k = 0; k < info.num_vertices(); ++k) st.x[info.vertex_begin + k] = anim->keys.front()[k];
  op.motion.animation = std::move(anim);
  op.shape.type = AnalyticShape::Type::none;  // the mesh moves on its own: no rigid analytic shape
}

/// An obstacle moved by keyframed rigid transforms of its placed geometry.
void read_keyframes(const Input& in, const YAML::Node& o, const ObjectInfo& info, SimState& st, ObjectParams& op,
                    const std::string& path) {
  const YAML::Node keys = o["keyframes"];
  const std::string kpath = path + ".keyframes";
  if (info.kind != ObjectKind::obstacle)
    in.ctx.fail(kpath, in.in_node(kpath), "only obstacles can be keyframed", {path + ".kind"});
  if (op.motion.moves())
    in.ctx.fail(kpath, in.in_node(kpath), "an object has one of `motion`, `animation` and `keyframes`");
  if (keys.size() == 0) in.ctx.fail(kpath, in.in_node(kpath), "list at least one key");
  auto anim = std::make_shared<VertexAnimation>();
  Vec3 prev_axis = Vec3::Zero();
  double prev_deg = 0;
  for (size_t k = 0; k < keys.size(); ++k) {
    const YAML::Node key = keys[k];
    const std::string p = kpath + "[" + std::to_string(k) + "]";
    const double t = key["time"].as<double>();
    if (k > 0 && !(t > anim->times.back()))
      in.ctx.fail(p + ".time", in.in_node(p + ".time"), "key times must increase",
                  {kpath + "[" + std::to_string(k - 1) + "].time"});
    const Vec3 axis = v3(key["rotate_axis"]), c = v3(key["center"]);
    const double ang = key["rotate_deg"].as<double>() * std::numbers::pi / 180.0;
    check_rotation(in, key, p);
    // Keys are slerped, which takes the shorter way round (at most 180°): a turn of 180° or more
    // between two keys about one axis would run backwards (270°) or not at all (360°).
    // A key at 0° has no axis of its own (the identity): it pairs with any axis.
    const double deg = key["rotate_deg"].as<double>();
    if (k > 0 && (deg == 0.0 || prev_deg == 0.0 || (axis.norm() > 0 && prev_axis.norm() > 0))) {
      const Vec3 a = deg == 0.0 ? Vec3::UnitY() : axis.normalized();
      const Vec3 b = prev_deg == 0.0 ? a : prev_axis.normalized();
      const double sign = a.dot(b) > 0 ? 1.0 : -1.0;  // [0,-1,0] at -90° is [0,1,0] at 90°
      if (deg == 0.0 || (a - sign * b).norm() < 1e-12) {
        const double turn = deg - sign * prev_deg;
        if (std::abs(turn) >= 180.0)
          in.ctx.fail(p + ".rotate_deg", in.in_node(p + ".rotate_deg"),
                      "turns " + ccfr::format("{:g}", turn) +
                          "° from the key before; keys are interpolated the "
                          "shorter way round (slerp, at most 180°), so this turn would not happen: split it into keys "
                          "less than 180° apart",
                      {kpath + "[" + std::to_string(k - 1) + "].rotate_deg"});
      }
    }
    prev_axis = axis;
    prev_deg = deg;
    if (k > 0 && (c - anim->center).norm() > 0)
      in.ctx.fail(p + ".center", in.in_node(p + ".center"), "every key rotates about the same center",
                  {kpath + "[0].center"});
    anim->center = c;
    anim->times.push_back(t);
    anim->rotations.push_back(ang != 0.0 && axis.norm() > 0
                                  ? Eigen::Quaterniond(Eigen::AngleAxisd(ang, axis.normalized()))
                                  : Eigen::Quaterniond::Identity());
    anim->translations.push_back(v3(key["translate"]));
  }
  anim->rest.assign(st.x.begin() + info.vertex_begin, st.x.begin() + info.vertex_end);
  for (Index k = 0; k < info.num_vertices(); ++k) st.x[info.vertex_begin + k] = anim->at(k, 0.0);
  op.motion.animation = std::move(anim);
  op.shape.type = AnalyticShape::Type::none;
}

void read_pins(const Input& in, const YAML::Node& pins, const ObjectInfo& info, SimState& st, ObjectParams& op,
               const std::string& path) {
  if (!pins) return;
  // A vertex in two groups that move it differently would follow only the last one.
  const auto same_motion = [](const Motion& a, const Motion& b) {
    if (!a.moves() && !b.moves()) return true;
    return a.velocity == b.velocity && a.axis == b.axis && a.center == b.center &&
           a.angular_velocity == b.angular_velocity && a.start == b.start && a.end == b.end;
  };
  std::vector<int> group_of(static_cast<size_t>(info.num_vertices()), -1);
  for (size_t k = 0; k < pins.size(); ++k) {
    const YAML::Node pn = pins[k];
    const std::string pp = path + ".pins[" + std::to_string(k) + "]";
    PinGroup grp;
    grp.motion = read_motion(pn["motion"]);
    check_motion(in, pn["motion"], pp + ".motion");
    if (pn["indices"])
      for (size_t j = 0; j < pn["indices"].size(); ++j) {
        const Index li = pn["indices"][j].as<Index>();
        if (li >= info.num_vertices())
          in.ctx.fail(pp + ".indices[" + std::to_string(j) + "]", in.in_node(pp + ".indices"),
                      "vertex index " + std::to_string(li) + " out of range: the object has " +
                          std::to_string(info.num_vertices()) + " vertices");
        grp.vertices.push_back(li);
      }
    if (static_cast<bool>(pn["box_min"]) != static_cast<bool>(pn["box_max"]))
      in.ctx.fail(pp, in.in_node(pp), "box_min and box_max go together");
    if (pn["box_min"]) {
      const Vec3 lo = v3(pn["box_min"]), hi = v3(pn["box_max"]);
      for (Index v = info.vertex_begin; v < info.vertex_end; ++v)
        if ((st.x[v].array() >= lo.array()).all() && (st.x[v].array() <= hi.array()).all())
          grp.vertices.push_back(v - info.vertex_begin);
    }
    if (grp.vertices.empty())
      in.ctx.fail(pp, in.in_node(pp), "pin group selects no vertex (give indices or a box that contains vertices)");
    for (const Index v : grp.vertices) {
      int& g = group_of[static_cast<size_t>(v)];
      if (g >= 0 && !same_motion(op.pins[static_cast<size_t>(g)].motion, grp.motion)) {
        const std::string other = path + ".pins[" + std::to_string(g) + "]";
        in.ctx.fail(pp, in.in_node(pp),
                    "vertex " + std::to_string(v) + " is also in " + other +
                        ", which moves it differently: it would follow only this group; keep each vertex in one "
                        "moving group",
                    {other});
      }
      g = static_cast<int>(k);
    }
    op.pins.push_back(std::move(grp));
  }
}

}  // namespace ccfr::io::scene
