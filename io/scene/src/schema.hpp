#pragma once
// A declarative schema for YAML configuration: one tree of typed nodes drives validation (unknown
// keys, types, ranges, choices, each error with file, key path and line), default filling (the
// resolved configuration written to run.json) and the generated key reference (docs/config.md).
// Private to io/: yaml-cpp never appears in a public header.
#include <yaml-cpp/yaml.h>

#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace ccfr::io::schema {

enum class Kind {
  map,
  list,
  number,
  integer,
  boolean,
  string,
  choice,
  vec3,
  vec2,
  ivec3,
  ivec2,
  index_list,
  dict,
  variant
};

struct Node;
using NodePtr = std::shared_ptr<Node>;

struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;
  static Range positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Range non_negative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
  static Range at_least(double v) { return {v, std::numeric_limits<double>::infinity(), false, false}; }
  static Range unit() { return {0.0, 1.0, false, false}; }
  static Range any() { return {}; }
  static Range within(double m) { return {-m, m, false, false}; }          ///< [-m, m]
  static Range positive_up_to(double m) { return {0.0, m, true, false}; }  ///< (0, m]
  static Range up_to(double m) { return {0.0, m, false, false}; }          ///< [0, m]
  bool contains(double v) const;
  std::string describe() const;  ///< e.g. "> 0", ">= 1", "in [0, 1]"; empty for any
};

struct Field {
  std::string key;
  NodePtr node;
};

struct Node {
  Kind kind = Kind::string;
  std::string doc;
  std::optional<std::string> default_yaml;  ///< YAML text of the default; nullopt and required: must be given
  bool required = false;
  bool optional_absent = false;  ///< no default and may be absent (e.g. `mesh`)
  Range range;
  std::function<std::vector<std::string>()> choices;      ///< choice
  std::vector<Field> fields;                              ///< map
  NodePtr item;                                           ///< list item, dict value
  std::string discriminator;                              ///< variant: key that names the variant
  std::vector<std::pair<std::string, NodePtr>> variants;  ///< variant name -> map of its other keys
};

// Builders.
NodePtr number(double def, std::string doc, Range r = {});
NodePtr required_number(std::string doc, Range r = {});
NodePtr integer(long long def, std::string doc, Range r = {});
NodePtr boolean(bool def, std::string doc);
NodePtr string(std::optional<std::string> def, std::string doc);
NodePtr optional_string(std::string doc);
NodePtr choice(std::string def, std::function<std::vector<std::string>()> choices, std::string doc);
NodePtr vec3(std::optional<std::array<double, 3>> def, std::string doc, Range r = {});
NodePtr vec2(std::optional<std::array<double, 2>> def, std::string doc, Range r = {});
NodePtr ivec3(std::optional<std::array<long long, 3>> def, std::string doc, Range r = {});
NodePtr ivec2(std::optional<std::array<long long, 2>> def, std::string doc, Range r = {});
NodePtr index_list(std::string doc);
NodePtr map(std::string doc, std::vector<Field> fields);
NodePtr optional_map(std::string doc, std::vector<Field> fields);  ///< absent unless given
NodePtr list(std::string doc, NodePtr item);
NodePtr dict(std::string doc, NodePtr value);
NodePtr variant(std::string doc, std::string discriminator, std::vector<std::pair<std::string, NodePtr>> variants);

/// Where an error points: the config file, and the key paths set from the command line.
struct Context {
  std::string file;
  std::vector<std::pair<std::string, std::string>> overrides;  ///< (key path, "--set ..." text)
  /// Throws a ConfigError at `path`. When `path`, or one of the `related` key paths that the
  /// check also depends on (e.g. the object's kind for a shape that cannot make it), was set
  /// from the command line, the error names that `--set` instead of the file.
  [[noreturn]] void fail(const std::string& path, const YAML::Node& at, const std::string& message,
                         const std::vector<std::string>& related = {}) const;
};

/// Validates `in` against `schema` and returns a new tree with every default filled in.
YAML::Node resolve(const YAML::Node& in, const NodePtr& schema, const Context& ctx, const std::string& path = "");

/// Applies one "key.path=value" override (value parsed as YAML) to `root`. List elements are
/// addressed by index (`objects.0`, `objects[0]`) or by their `name` (`objects.sheet`). A map
/// value is merged into a map already there key by key (`time={frames: 3}` is `time.frames=3`),
/// unless it names another variant (`shape={type: sphere, ...}` over a mesh replaces the shape).
/// Returns the normalised key path. A node of `root` in the way that `schema` says must be a map
/// or list is the scene file's error (ConfigError naming `file` and its line); other mistakes are
/// the override's (Error naming `--set assignment`).
std::string apply_override(YAML::Node& root, const std::string& assignment, const NodePtr& schema = nullptr,
                           const std::string& file = "");

/// Emits a resolved tree as JSON, typed by the schema (numbers stay numbers), two spaces per
/// level; every line after the first is indented by `indent` more.
std::string to_json(const YAML::Node& resolved, const NodePtr& schema, int indent = 0);

/// Markdown reference of every key: path, type, default, range/choices, description.
std::string reference_markdown(const NodePtr& schema);

}  // namespace ccfr::io::schema
