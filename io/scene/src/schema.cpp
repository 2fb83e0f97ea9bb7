#include "schema.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <sstream>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>
#include <nlohmann/json.hpp>

#include "ccfr/core/error.hpp"
#include "ccfr/io/user_file.hpp"

namespace ccfr::io::schema {

namespace {

NodePtr make(Kind k, std::string doc) {
  auto n = std::make_shared<Node>();
  n->kind = k;
  n->doc = std::move(doc);
  return n;
}

std::string fmt_double(double v) {
  char buf[64];
  auto res = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, res.ptr);
  return s;
}

template <size_t N, class T>
std::string fmt_array(const std::array<T, N>& a) {
  std::string s = "[";
  for (size_t i = 0; i < N; ++i) {
    if (i) s += ", ";
    if constexpr (std::is_floating_point_v<T>)
      s += fmt_double(a[i]);
    else
      s += std::to_string(a[i]);
  }
  return s + "]";
}

size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0u : 1u)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string suggest(const std::string& key, const std::vector<std::string>& valid) {
  std::string best;
  size_t best_d = 3;  // suggest only close matches
  for (const auto& v : valid) {
    const size_t d = edit_distance(key, v);
    if (d < best_d) best_d = d, best = v;
  }
  std::string msg;
  if (!best.empty()) msg += " (did you mean '" + best + "'?)";
  std::string list;
  for (const auto& v : valid) list += (list.empty() ? "" : ", ") + v;
  return msg + "; valid: " + list;
}

std::string join(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

std::string kind_name(Kind k) {
  switch (k) {
    case Kind::map:
      return "map";
    case Kind::list:
      return "list";
    case Kind::number:
      return "number";
    case Kind::integer:
      return "integer";
    case Kind::boolean:
      return "boolean";
    case Kind::string:
      return "string";
    case Kind::choice:
      return "choice";
    case Kind::vec3:
      return "[x, y, z]";
    case Kind::vec2:
      return "[a, b]";
    case Kind::ivec3:
      return "[i, j, k]";
    case Kind::ivec2:
      return "[i, j]";
    case Kind::index_list:
      return "list of indices";
    case Kind::dict:
      return "map of name -> entry";
    case Kind::variant:
      return "map";
  }
  return "?";
}

bool parse_double(const YAML::Node& n, double& out) {
  if (!n.IsScalar()) return false;
  const std::string& s = n.Scalar();
  if (s.empty()) return false;
  const char* b = s.c_str();
  char* e = nullptr;
  out = std::strtod(b, &e);
  if (e == b || *e != '\0') {
    // YAML spellings of infinity / NaN parse but are rejected later as non-finite.
    if (s == ".inf" || s == "+.inf" || s == ".Inf")
      out = INFINITY;
    else if (s == "-.inf" || s == "-.Inf")
      out = -INFINITY;
    else if (s == ".nan" || s == ".NaN" || s == "nan" || s == "NaN")
      out = NAN;
    else
      return false;
  }
  return true;
}

bool parse_integer(const YAML::Node& n, long long& out, bool* too_large = nullptr) {
  if (!n.IsScalar()) return false;
  const std::string& s = n.Scalar();
  const char* b = s.data();
  if (s.size() > 1 && s[0] == '+') ++b;  // YAML allows a leading '+'
  auto res = std::from_chars(b, s.data() + s.size(), out);
  if (res.ec == std::errc::result_out_of_range && res.ptr == s.data() + s.size()) {
    if (too_large) *too_large = true;
    return false;
  }
  return res.ec == std::errc() && res.ptr == s.data() + s.size();
}

/// Every integer of the schema ends as a 32-bit `int` / `Index`: values beyond it are range errors.
Range int32_range(const Range& r) {
  Range out = r;
  const double lo = std::numeric_limits<std::int32_t>::min(), hi = std::numeric_limits<std::int32_t>::max();
  if (!(out.lo > lo)) out.lo = lo, out.lo_open = false;
  if (!(out.hi < hi)) out.hi = hi, out.hi_open = false;
  return out;
}

YAML::Node scalar_number(const YAML::Node& in, const NodePtr& sch, const Context& ctx, const std::string& path) {
  double v;
  if (!parse_double(in, v))
    ctx.fail(path, in,
             "expected a number, got " + (in.IsScalar() ? "'" + in.Scalar() + "'"
                                                        : std::string("a ") + (in.IsSequence() ? "list"
                                                                               : in.IsMap()    ? "map"
                                                                                               : "null value")));
  if (!std::isfinite(v)) ctx.fail(path, in, "must be finite, got '" + in.Scalar() + "'");
  if (!sch->range.contains(v))
    ctx.fail(path, in, "value " + in.Scalar() + " out of range: must be " + sch->range.describe());
  return YAML::Node(fmt_double(v));  // shortest round-trip text, so run.json shows 0.005, not 0.0050000000000000001
}

YAML::Node scalar_integer(const YAML::Node& in, const NodePtr& sch, const Context& ctx, const std::string& path) {
  long long v;
  bool too_large = false;
  const Range r = int32_range(sch->range);
  if (!parse_integer(in, v, &too_large)) {
    if (too_large) ctx.fail(path, in, "value " + in.Scalar() + " out of range: must be " + r.describe());
    ctx.fail(path, in,
             "expected an integer, got " + (in.IsScalar() ? "'" + in.Scalar() + "'"
                                                          : std::string("a ") + (in.IsSequence() ? "list"
                                                                                 : in.IsMap()    ? "map"
                                                                                                 : "null value")));
  }
  if (!r.contains(static_cast<double>(v)))
    ctx.fail(path, in, "value " + in.Scalar() + " out of range: must be " + r.describe());
  return YAML::Node(v);
}

YAML::Node fixed_vector(const YAML::Node& in, const NodePtr& sch, const Context& ctx, const std::string& path, size_t n,
                        bool integral) {
  if (!in.IsSequence() || in.size() != n)
    ctx.fail(path, in,
             "expected a list of " + std::to_string(n) + (integral ? " integers" : " numbers") + " like " +
                 kind_name(sch->kind));
  YAML::Node out(YAML::NodeType::Sequence);
  for (size_t i = 0; i < n; ++i) {
    const std::string p = path + "[" + std::to_string(i) + "]";
    out.push_back(integral ? scalar_integer(in[i], sch, ctx, p) : scalar_number(in[i], sch, ctx, p));
  }
  return out;
}

std::vector<std::string> field_keys(const Node& n) {
  std::vector<std::string> k;
  for (const auto& f : n.fields) k.push_back(f.key);
  return k;
}

/// Keys must be plain strings and appear once: YAML parsers keep the first of two equal keys and
/// silently drop the second (`time: {fps: 60, fps: -5}` would run at 60).
void check_keys(const YAML::Node& in, const Context& ctx, const std::string& path) {
  std::vector<std::pair<std::string, YAML::Node>> seen;
  for (auto it = in.begin(); it != in.end(); ++it) {
    const YAML::Node k = it->first;
    if (!k.IsScalar())
      ctx.fail(path, k,
               std::string("keys must be strings, got a ") + (k.IsSequence() ? "list"
                                                              : k.IsMap()    ? "map"
                                                                             : "null key"));
    for (const auto& [name, first] : seen)
      if (name == k.Scalar()) {
        const int line = first.Mark().is_null() ? 0 : first.Mark().line + 1;
        ctx.fail(join(path, name), k,
                 "duplicate key '" + name + "'" +
                     (line > 0 ? " (first given on line " + std::to_string(line) + ")" : std::string()));
      }
    seen.emplace_back(k.Scalar(), k);
  }
}

YAML::Node resolve_map_fields(const YAML::Node& in, const Node& sch, const Context& ctx, const std::string& path,
                              const std::string& skip_key = "") {
  if (in.IsDefined() && !in.IsNull() && !in.IsMap()) ctx.fail(path, in, "expected a map of keys");
  YAML::Node out(YAML::NodeType::Map);
  if (in.IsMap()) {
    check_keys(in, ctx, path);
    for (auto it = in.begin(); it != in.end(); ++it) {
      const std::string key = it->first.Scalar();
      if (key == skip_key) continue;
      const bool known =
          std::any_of(sch.fields.begin(), sch.fields.end(), [&](const Field& f) { return f.key == key; });
      if (!known) {
        auto valid = field_keys(sch);
        ctx.fail(join(path, key), it->first, "unknown key '" + key + "'" + suggest(key, valid));
      }
    }
  }
  for (const auto& f : sch.fields) {
    const std::string p = join(path, f.key);
    const bool present = in.IsMap() && in[f.key].IsDefined();
    if (present) {
      out[f.key] = resolve(in[f.key], f.node, ctx, p);
    } else if (f.node->required) {
      ctx.fail(p, in, "missing required key '" + f.key + "'");
    } else if (f.node->default_yaml) {
      out[f.key] = resolve(YAML::Load(*f.node->default_yaml), f.node, ctx, p);
    } else if (f.node->kind == Kind::map || f.node->kind == Kind::dict || f.node->kind == Kind::list) {
      if (!f.node->optional_absent) out[f.key] = resolve(YAML::Node(), f.node, ctx, p);
    }
  }
  return out;
}

}  // namespace

bool Range::contains(double v) const {
  if (lo_open ? !(v > lo) : !(v >= lo)) return false;
  if (hi_open ? !(v < hi) : !(v <= hi)) return false;
  return true;
}

std::string Range::describe() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi)
    return std::string("in ") + (lo_open ? "(" : "[") + fmt_double(lo) + ", " + fmt_double(hi) + (hi_open ? ")" : "]");
  if (has_lo) return std::string(lo_open ? "> " : ">= ") + fmt_double(lo);
  if (has_hi) return std::string(hi_open ? "< " : "<= ") + fmt_double(hi);
  return "";
}

NodePtr number(double def, std::string doc, Range r) {
  auto n = make(Kind::number, std::move(doc));
  n->default_yaml = fmt_double(def);
  n->range = r;
  return n;
}
NodePtr required_number(std::string doc, Range r) {
  auto n = make(Kind::number, std::move(doc));
  n->required = true;
  n->range = r;
  return n;
}
NodePtr integer(long long def, std::string doc, Range r) {
  auto n = make(Kind::integer, std::move(doc));
  n->default_yaml = std::to_string(def);
  n->range = r;
  return n;
}
NodePtr boolean(bool def, std::string doc) {
  auto n = make(Kind::boolean, std::move(doc));
  n->default_yaml = def ? "true" : "false";
  return n;
}
NodePtr string(std::optional<std::string> def, std::string doc) {
  auto n = make(Kind::string, std::move(doc));
  if (def)
    n->default_yaml = "'" + *def + "'";
  else
    n->required = true;
  return n;
}
NodePtr optional_string(std::string doc) {
  auto n = make(Kind::string, std::move(doc));
  n->optional_absent = true;
  return n;
}
NodePtr choice(std::string def, std::function<std::vector<std::string>()> choices, std::string doc) {
  auto n = make(Kind::choice, std::move(doc));
  n->default_yaml = "'" + def + "'";
  n->choices = std::move(choices);
  return n;
}
namespace {
/// A fixed-length array node: its default written as YAML, or, without one, `absent` (vec3: may be
/// left out) or required (the others).
template <class T, size_t N>
NodePtr array_node(Kind kind, const std::optional<std::array<T, N>>& def, std::string doc, Range r, bool absent) {
  auto n = make(kind, std::move(doc));
  if (def)
    n->default_yaml = fmt_array(*def);
  else if (absent)
    n->optional_absent = true;
  else
    n->required = true;
  n->range = r;
  return n;
}
}  // namespace
NodePtr vec3(std::optional<std::array<double, 3>> def, std::string doc, Range r) {
  return array_node(Kind::vec3, def, std::move(doc), r, true);
}
NodePtr vec2(std::optional<std::array<double, 2>> def, std::string doc, Range r) {
  return array_node(Kind::vec2, def, std::move(doc), r, false);
}
NodePtr ivec3(std::optional<std::array<long long, 3>> def, std::string doc, Range r) {
  return array_node(Kind::ivec3, def, std::move(doc), r, false);
}
NodePtr ivec2(std::optional<std::array<long long, 2>> def, std::string doc, Range r) {
  return array_node(Kind::ivec2, def, std::move(doc), r, false);
}
NodePtr index_list(std::string doc) {
  auto n = make(Kind::index_list, std::move(doc));
  n->optional_absent = true;
  n->range = Range::non_negative();
  return n;
}
NodePtr map(std::string doc, std::vector<Field> fields) {
  auto n = make(Kind::map, std::move(doc));
  n->fields = std::move(fields);
  return n;
}
NodePtr optional_map(std::string doc, std::vector<Field> fields) {
  auto n = map(std::move(doc), std::move(fields));
  n->optional_absent = true;
  return n;
}
NodePtr list(std::string doc, NodePtr item) {
  auto n = make(Kind::list, std::move(doc));
  n->item = std::move(item);
  n->optional_absent = true;
  return n;
}
NodePtr dict(std::string doc, NodePtr value) {
  auto n = make(Kind::dict, std::move(doc));
  n->item = std::move(value);
  return n;
}
NodePtr variant(std::string doc, std::string discriminator, std::vector<std::pair<std::string, NodePtr>> variants) {
  auto n = make(Kind::variant, std::move(doc));
  n->discriminator = std::move(discriminator);
  n->variants = std::move(variants);
  n->required = true;
  return n;
}

void Context::fail(const std::string& raw_path, const YAML::Node& at, const std::string& raw_message,
                   const std::vector<std::string>& related) const {
  // A key may hold any character YAML can escape (a NUL cut the message): shown as \xNN.
  const std::string path = printable(raw_path), message = printable(raw_message, /*keep_newlines=*/true);
  auto under = [](const std::string& p, const std::string& opath) {
    return p == opath || p.rfind(opath + ".", 0) == 0 || p.rfind(opath + "[", 0) == 0;
  };
  for (const auto& [opath, text] : overrides) {
    if (under(raw_path, opath)) throw ConfigError("command line (" + text + ")", path, 0, message);
  }
  for (const auto& [opath, text] : overrides)
    for (const auto& r : related)
      if (under(r, opath)) throw ConfigError("command line (" + text + ")", r, 0, message);
  int line = 0;
  if (at.IsDefined() && !at.Mark().is_null()) line = at.Mark().line + 1;
  throw ConfigError(file, path, line, message);
}

YAML::Node resolve(const YAML::Node& in, const NodePtr& sch, const Context& ctx, const std::string& path) {
  switch (sch->kind) {
    case Kind::map:
      return resolve_map_fields(in, *sch, ctx, path);
    case Kind::list: {
      if (in.IsNull() || !in.IsDefined()) return YAML::Node(YAML::NodeType::Sequence);
      if (!in.IsSequence()) ctx.fail(path, in, "expected a list");
      YAML::Node out(YAML::NodeType::Sequence);
      for (size_t i = 0; i < in.size(); ++i)
        out.push_back(resolve(in[i], sch->item, ctx, path + "[" + std::to_string(i) + "]"));
      return out;
    }
    case Kind::dict: {
      if (in.IsNull() || !in.IsDefined()) return YAML::Node(YAML::NodeType::Map);
      if (!in.IsMap()) ctx.fail(path, in, "expected a map of named entries");
      check_keys(in, ctx, path);
      YAML::Node out(YAML::NodeType::Map);
      for (auto it = in.begin(); it != in.end(); ++it) {
        const std::string key = it->first.Scalar();
        out[key] = resolve(it->second, sch->item, ctx, join(path, key));
      }
      return out;
    }
    case Kind::variant: {
      if (!in.IsMap()) ctx.fail(path, in, "expected a map with a '" + sch->discriminator + "' key");
      const YAML::Node tag = in[sch->discriminator];
      std::vector<std::string> names;
      for (const auto& v : sch->variants) names.push_back(v.first);
      if (!tag.IsDefined())
        ctx.fail(join(path, sch->discriminator), in,
                 "missing required key '" + sch->discriminator + "'; valid: " + suggest("", names).substr(9));
      const std::string t = tag.IsScalar() ? tag.Scalar() : "";
      for (const auto& [name, vsch] : sch->variants) {
        if (name != t) continue;
        YAML::Node out = resolve_map_fields(in, *vsch, ctx, path, sch->discriminator);
        YAML::Node tagged(YAML::NodeType::Map);
        tagged[sch->discriminator] = t;
        for (auto it = out.begin(); it != out.end(); ++it) tagged[it->first] = it->second;
        return tagged;
      }
      ctx.fail(join(path, sch->discriminator), tag,
               "unknown " + sch->discriminator + " '" + t + "'" + suggest(t, names));
    }
    case Kind::number:
      return scalar_number(in, sch, ctx, path);
    case Kind::integer:
      return scalar_integer(in, sch, ctx, path);
    case Kind::boolean: {
      bool b = false;
      if (!in.IsScalar() || !YAML::convert<bool>::decode(in, b)) ctx.fail(path, in, "expected true or false");
      return YAML::Node(b);
    }
    case Kind::string:
      if (!in.IsScalar()) ctx.fail(path, in, "expected a string");
      return YAML::Node(in.Scalar());
    case Kind::choice: {
      const auto valid = sch->choices();
      if (!in.IsScalar()) ctx.fail(path, in, "expected one of the names" + suggest("", valid).substr(0));
      if (std::find(valid.begin(), valid.end(), in.Scalar()) == valid.end())
        ctx.fail(path, in, "unknown value '" + in.Scalar() + "'" + suggest(in.Scalar(), valid));
      return YAML::Node(in.Scalar());
    }
    case Kind::vec3:
      return fixed_vector(in, sch, ctx, path, 3, false);
    case Kind::vec2:
      return fixed_vector(in, sch, ctx, path, 2, false);
    case Kind::ivec3:
      return fixed_vector(in, sch, ctx, path, 3, true);
    case Kind::ivec2:
      return fixed_vector(in, sch, ctx, path, 2, true);
    case Kind::index_list: {
      if (!in.IsSequence()) ctx.fail(path, in, "expected a list of vertex indices");
      YAML::Node out(YAML::NodeType::Sequence);
      for (size_t i = 0; i < in.size(); ++i)
        out.push_back(scalar_integer(in[i], sch, ctx, path + "[" + std::to_string(i) + "]"));
      return out;
    }
  }
  ctx.fail(path, in, "internal: unhandled schema kind");
}

namespace {
/// Counts the documents of a YAML stream; stops at a document that starts where the last one did
/// (yaml-cpp 0.7 then loops forever, see scene/yaml_text.cpp).
class DocumentCount : public YAML::EventHandler {
 public:
  int count = 0;
  int last_pos = -1;
  bool stuck = false;
  void OnDocumentStart(const YAML::Mark& m) override {
    stuck = m.pos == last_pos;
    last_pos = m.pos;
    ++count;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

/// The value of a --set: one YAML document. YAML::Load keeps the first document of several
/// and drops the rest without a word ("1\n---\n2" would set 1).
YAML::Node load_override_value(const std::string& value, const std::string& assignment) {
  std::istringstream in(value);
  YAML::Parser parser(in);
  DocumentCount docs;
  while (parser.HandleNextDocument(docs) && !docs.stuck)
    if (docs.count > 1)
      throw Error("--set '" + assignment +
                  "': the value holds a second YAML document (after '---' or '...'); give one value");
  return YAML::Load(value);
}

/// The schema node of `key` under `n` (a list's or dict's item, a map's or variant's field); null
/// when unknown.
const Node* child_schema(const Node* n, const std::string& key) {
  if (!n) return nullptr;
  const Node* next = nullptr;
  if (n->kind == Kind::list || n->kind == Kind::dict) next = n->item.get();
  for (const auto& f : n->fields)
    if (f.key == key) next = f.node.get();
  for (const auto& [name, v] : n->variants)
    for (const auto& f : v->fields)
      if (f.key == key) next = f.node.get();
  return next;
}

/// True if `value` is written into the map `there` key by key rather than replacing it: both are
/// maps, `value` non-empty, and it keeps the variant (a mesh shape set to a sphere is replaced
/// whole: the mesh's keys do not belong to a sphere).
bool merges(const YAML::Node& there, const YAML::Node& value, const Node* sn) {
  if (!value.IsMap() || value.size() == 0 || !there.IsMap()) return false;
  if (!sn || sn->kind != Kind::variant || !value[sn->discriminator]) return true;
  const YAML::Node was = there[sn->discriminator], now = value[sn->discriminator];
  return was && was.IsScalar() && now.IsScalar() && was.Scalar() == now.Scalar();
}

/// Writes the map `value` into the map `target` key by key, recursively (as a key path per leaf
/// would); `sn` is the schema node of `target`.
void merge_into(YAML::Node target, const YAML::Node& value, const Node* sn) {
  for (auto it = value.begin(); it != value.end(); ++it) {
    const std::string key = it->first.as<std::string>();
    const Node* sub = child_schema(sn, key);
    if (merges(target[key], it->second, sub))
      merge_into(target[key], it->second, sub);
    else
      target[key] = it->second;
  }
}

/// Sets `parent[key]` (a map's key or a list's index) to `value`, merged into a map already there
/// (merges); `sn` is the schema node of the key.
template <class Key>
void set_value(YAML::Node parent, const Key& key, const YAML::Node& value, const Node* sn) {
  if (merges(parent[key], value, sn))
    merge_into(parent[key], value, sn);
  else
    parent[key] = value;
}
}  // namespace

std::string apply_override(YAML::Node& root, const std::string& assignment, const NodePtr& sch,
                           const std::string& file) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw Error("--set '" + assignment + "': expected key.path=value");
  std::string key = assignment.substr(0, eq);
  const std::string value = assignment.substr(eq + 1);
  for (char& c : key)
    if (c == '[' || c == ']') c = '.';
  std::vector<std::string> segs;
  std::stringstream ss(key);
  for (std::string s; std::getline(ss, s, '.');)
    if (!s.empty()) segs.push_back(s);
  if (segs.empty()) throw Error("--set '" + assignment + "': empty key path");

  std::string norm;
  YAML::Node cur;
  cur.reset(root);
  const Node* sn = sch.get();  // the schema node at `norm` (null when unknown)
  // A node in the way that is not a map: if the schema wants a map or list there, the scene file
  // is wrong (blame it, with its line); otherwise the --set key path is.
  auto not_a_container = [&](const YAML::Node& n) {
    const std::string got = n.IsScalar() ? "'" + n.Scalar() + "'" : n.IsSequence() ? "a list" : "a map";
    if (sn &&
        (sn->kind == Kind::map || sn->kind == Kind::variant || sn->kind == Kind::dict || sn->kind == Kind::list)) {
      const int line = n.Mark().is_null() ? 0 : n.Mark().line + 1;
      throw ConfigError(
          file, norm, line,
          std::string(sn->kind == Kind::list ? "expected a list" : "expected a map of keys") + ", got " + got);
    }
    throw Error("--set '" + assignment + "': '" + norm + "' is " + got + ", not a map of keys");
  };
  auto descend = [&](const std::string& seg) { sn = child_schema(sn, seg); };
  for (size_t i = 0; i < segs.size(); ++i) {
    const std::string& seg = segs[i];
    const bool last = i + 1 == segs.size();
    if (sn && sn->kind == Kind::list && cur.IsDefined() && !cur.IsNull() && !cur.IsSequence()) not_a_container(cur);
    if (cur.IsSequence()) {
      long long idx = -1;
      if (!parse_integer(YAML::Node(seg), idx)) {
        for (size_t k = 0; k < cur.size(); ++k)
          if (cur[k].IsMap() && cur[k]["name"] && cur[k]["name"].Scalar() == seg) idx = static_cast<long long>(k);
        if (idx < 0) throw Error("--set '" + assignment + "': no list element named '" + seg + "' at '" + norm + "'");
      }
      if (idx < 0 || idx >= static_cast<long long>(cur.size()))
        throw Error("--set '" + assignment + "': index " + seg + " out of range at '" + norm + "' (" +
                    std::to_string(cur.size()) + " elements)");
      norm += "[" + std::to_string(idx) + "]";
      descend(seg);
      if (last) {
        set_value(cur, static_cast<size_t>(idx), load_override_value(value, assignment), sn);
      } else {
        YAML::Node next = cur[static_cast<size_t>(idx)];
        cur.reset(next);
      }
    } else {
      if (!cur.IsMap() && !cur.IsNull() && cur.IsDefined()) not_a_container(cur);
      norm = join(norm, seg);
      descend(seg);
      if (last) {
        set_value(cur, seg, load_override_value(value, assignment), sn);
      } else {
        YAML::Node next = cur[seg];
        cur.reset(next);
      }
    }
  }
  return norm;
}

namespace {
using Json = nlohmann::ordered_json;

/// A resolved scalar's text as JSON: resolve() writes numbers in their shortest round-trip text
/// (an integral one without a fraction, so it reads as an integer), integers and booleans as JSON does.
Json scalar_json(const std::string& text) { return Json::parse(text); }

Json emit(const YAML::Node& n, const Node& sch);

/// The fields of `n` that are present, in the schema's order (`disc`, a variant's tag, first).
Json emit_map(const YAML::Node& n, const std::vector<Field>& fields, const std::string& disc = "") {
  Json o = Json::object();
  if (!disc.empty() && n[disc]) o[disc] = n[disc].Scalar();
  for (const auto& f : fields)
    if (n[f.key]) o[f.key] = emit(n[f.key], *f.node);
  return o;
}

Json emit(const YAML::Node& n, const Node& sch) {
  switch (sch.kind) {
    case Kind::map:
      return emit_map(n, sch.fields);
    case Kind::variant:
      for (const auto& [name, v] : sch.variants)
        if (n[sch.discriminator] && n[sch.discriminator].Scalar() == name)
          return emit_map(n, v->fields, sch.discriminator);
      return Json::object();
    case Kind::dict: {
      Json o = Json::object();
      for (auto it = n.begin(); it != n.end(); ++it) o[it->first.as<std::string>()] = emit(it->second, *sch.item);
      return o;
    }
    case Kind::list: {
      Json o = Json::array();
      for (size_t i = 0; i < n.size(); ++i) o.push_back(emit(n[i], *sch.item));
      return o;
    }
    case Kind::vec3:
    case Kind::vec2:
    case Kind::ivec3:
    case Kind::ivec2:
    case Kind::index_list: {
      Json o = Json::array();
      for (size_t i = 0; i < n.size(); ++i) o.push_back(scalar_json(n[i].Scalar()));
      return o;
    }
    case Kind::number: {
      double v = 0;
      parse_double(n, v);
      return scalar_json(fmt_double(v));
    }
    case Kind::integer:
    case Kind::boolean:
      return scalar_json(n.Scalar());
    case Kind::string:
    case Kind::choice:
      return n.Scalar();
  }
  return nullptr;
}

void reference_rows(std::string& o, const Node& sch, const std::string& path, const std::string& note) {
  auto row = [&](const std::string& p, const Node& n) {
    std::string type = kind_name(n.kind), allowed = n.range.describe(), def;
    if (n.kind == Kind::choice) {
      allowed.clear();
      for (const auto& c : n.choices()) allowed += (allowed.empty() ? "`" : ", `") + c + "`";
      type = "choice";
    }
    if (n.required)
      def = "required";
    else if (n.default_yaml)
      def = "`" + *n.default_yaml + "`";
    else
      def = "absent";
    if (!def.empty() && def.front() == '`') {
      // strip the YAML quotes of string defaults for readability
      std::string inner = def.substr(1, def.size() - 2);
      if (inner.size() >= 2 && inner.front() == '\'' && inner.back() == '\'') inner = inner.substr(1, inner.size() - 2);
      def = "`" + inner + "`";
    }
    o += "| `" + p + "` | " + type + " | " + def + " | " + allowed + " | " + n.doc + (note.empty() ? "" : " " + note) +
         " |\n";
  };
  switch (sch.kind) {
    case Kind::map:
      for (const auto& f : sch.fields) {
        const std::string p = path.empty() ? f.key : path + "." + f.key;
        if (f.node->kind == Kind::map || f.node->kind == Kind::list || f.node->kind == Kind::dict ||
            f.node->kind == Kind::variant) {
          if (f.node->kind != Kind::map || f.node->optional_absent) row(p, *f.node);
          reference_rows(o, *f.node, p, note);
        } else {
          row(p, *f.node);
        }
      }
      return;
    case Kind::list:
      reference_rows(o, *sch.item, path + "[]", note);
      return;
    case Kind::dict:
      reference_rows(o, *sch.item, path + ".<name>", note);
      return;
    case Kind::variant: {
      std::string names;
      for (const auto& v : sch.variants) names += (names.empty() ? "`" : ", `") + v.first + "`";
      o += "| `" + path + "." + sch.discriminator + "` | choice | required | " + names + " | selects the variant |\n";
      for (const auto& [name, v] : sch.variants)
        reference_rows(o, *v, path, "(" + sch.discriminator + ": " + name + ")");
      return;
    }
    default:
      row(path, sch);
  }
}
}  // namespace

std::string to_json(const YAML::Node& resolved, const NodePtr& sch, int indent) {
  const std::string text = emit(resolved, *sch).dump(2, ' ', false, Json::error_handler_t::replace);
  std::string o;
  for (const char c : text) {
    o += c;
    if (c == '\n') o.append(static_cast<size_t>(indent), ' ');
  }
  return o;
}

std::string reference_markdown(const NodePtr& sch) {
  std::string o = "| key | type | default | allowed | meaning |\n|---|---|---|---|---|\n";
  reference_rows(o, *sch, "", "");
  return o;
}

}  // namespace ccfr::io::schema
