#pragma once
/// @file registry.hpp
/// The one registry pattern of ccfr's pluggable components (contact solvers, broad phases,
/// projectors, output formats, material constraints). Each implementation registers its name, a
/// one-line description, the schema of its own parameters (keys, types, defaults, ranges, docs)
/// and a factory built from those parameters. YAML validation, `ccfr schema`, docs/config.md,
/// `--help`, `ccfr ablate` and the tests read the registries; downstream code adds entries through
/// the installed headers.
///
/// The libraries are static, so an implementation that registers itself through a global object
/// would be dropped by the linker unless something references it. Built-in entries are therefore
/// added by the registry's accessor on first use (each from its implementation's own file);
/// downstream code calls `add()` (or uses `Registration`) in a file of its executable.
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace ccfr {

/// Value of one component parameter. Integers are `long long`, as in the scene schema.
using ParamValue = std::variant<bool, long long, double, std::string>;

enum class ParamType { boolean, integer, number, choice };

/// One parameter of a component: its key (under the component's own section of the scene file,
/// e.g. `contact.toi_clamp.scale`), type, default, admissible range or choices, and description.
/// A material constraint's parameter may instead be a key of the material itself
/// (`material_key`, e.g. `materials.<m>.stretch_compliance`): see material_constraint.hpp.
struct ParamSpec {
  std::string key;
  ParamType type = ParamType::number;
  ParamValue default_value = 0.0;
  std::string doc;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false, max_open = false;  ///< open interval ends (e.g. (0, 1])
  std::vector<std::string> choices;         ///< ParamType::choice only
  /// Material constraints only: the key of the material section this parameter is read from,
  /// shared by every constraint that names it; empty: the key lies in the component's own section.
  std::string material_key;

  static ParamSpec number(std::string key, double def, std::string doc,
                          double min = -std::numeric_limits<double>::infinity(),
                          double max = std::numeric_limits<double>::infinity(), bool min_open = false,
                          bool max_open = false);
  static ParamSpec integer(std::string key, long long def, std::string doc,
                           long long min = std::numeric_limits<long long>::min(),
                           long long max = std::numeric_limits<long long>::max());
  static ParamSpec boolean(std::string key, bool def, std::string doc);
  static ParamSpec choice(std::string key, std::string def, std::vector<std::string> choices, std::string doc);
  /// This spec read from the material's key `key` (see `material_key`).
  ParamSpec from_material(std::string key) && {
    material_key = std::move(key);
    return std::move(*this);
  }

  /// Why `v` is not admissible ("must be > 0", "must be an integer", ...); empty if it is.
  std::string check(const ParamValue& v) const;
  /// The range as text for docs and errors, e.g. "in (0, 1]", ">= 1"; empty if unbounded.
  std::string describe_range() const;
};

/// Values of a component's parameters, by key. Built from a scene file (io), or in code.
class ParamValues {
 public:
  ParamValues() = default;
  ParamValues(std::initializer_list<std::pair<const std::string, ParamValue>> init) : values_(init) {}
  ParamValues& set(const std::string& key, ParamValue v) {
    values_[key] = std::move(v);
    return *this;
  }
  bool has(const std::string& key) const { return values_.count(key) > 0; }
  bool empty() const { return values_.empty(); }
  /// Typed access; throws std::logic_error for a missing key or another type (a factory asking
  /// for a key its own schema does not declare is a programming error). number() accepts integers.
  double number(const std::string& key) const;
  long long integer(const std::string& key) const;
  bool boolean(const std::string& key) const;
  const std::string& choice(const std::string& key) const;
  const std::map<std::string, ParamValue>& values() const { return values_; }

 private:
  const ParamValue& at(const std::string& key) const;
  std::map<std::string, ParamValue> values_;
};

/// The values of `given` checked against `specs` (unknown keys, types, ranges, choices) with every
/// missing key set to its default. Errors are ccfr::Error naming `where` and the key, e.g.
/// "contact solver 'toi_clamp': parameter 'scale' must be in (0, 1]; got 2".
ParamValues complete_params(std::span<const ParamSpec> specs, const ParamValues& given, std::string_view where);

/// A registry of one kind of component. `Args` are the factory's arguments besides the parameters.
template <class Product, class... Args>
class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Product>(const ParamValues&, Args...)>;
  struct Entry {
    std::string name;         ///< the key in scene files and on the command line
    std::string description;  ///< one line, for `ccfr schema`, docs/config.md and --help
    std::vector<ParamSpec> params;
    Factory make;
  };

  /// `kind` names the component in messages ("contact solver", "broad phase", "projector").
  explicit Registry(std::string kind) : kind_(std::move(kind)) {}

  /// Adds an entry. Throws ccfr::Error for an empty or taken name, duplicate parameter keys, a
  /// default that violates its own range, or a missing factory.
  void add(Entry e);
  /// The entry named `name`, or nullptr.
  const Entry* find(std::string_view name) const {
    for (const auto& e : entries_)
      if (e.name == name) return &e;
    return nullptr;
  }
  /// The entry named `name`; throws ccfr::Error listing the registered names.
  const Entry& at(std::string_view name) const;
  /// Registered names, in registration order.
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& e : entries_) out.push_back(e.name);
    return out;
  }
  const std::deque<Entry>& entries() const { return entries_; }
  const std::string& kind() const { return kind_; }

  /// Creates `name` from `given` (checked, defaults filled in) and `args`.
  std::unique_ptr<Product> make(std::string_view name, const ParamValues& given, Args... args) const {
    const Entry& e = at(name);
    return e.make(complete_params(e.params, given, kind_ + " '" + e.name + "'"), std::forward<Args>(args)...);
  }

 private:
  std::string kind_;
  std::deque<Entry> entries_;  ///< a deque: find() pointers stay valid when entries are added
};

/// Adds an entry at static initialisation, for a file of an executable (object files of a static
/// library are dropped unless referenced, so a library calls `add()` from a function instead):
///   static ccfr::Registration<ccfr::ContactSolverRegistry> reg(ccfr::contact_solvers(), {...});
template <class R>
struct Registration {
  Registration(R& registry, typename R::Entry entry) { registry.add(std::move(entry)); }
};

namespace detail {
[[noreturn]] void registry_unknown(const std::string& kind, std::string_view name,
                                   const std::vector<std::string>& names);
void registry_check_entry(const std::string& kind, const std::string& name, bool has_factory,
                          std::span<const ParamSpec> params, bool taken);
}  // namespace detail

template <class Product, class... Args>
void Registry<Product, Args...>::add(Entry e) {
  detail::registry_check_entry(kind_, e.name, static_cast<bool>(e.make), e.params, find(e.name) != nullptr);
  entries_.push_back(std::move(e));
}

template <class Product, class... Args>
const typename Registry<Product, Args...>::Entry& Registry<Product, Args...>::at(std::string_view name) const {
  if (const Entry* e = find(name)) return *e;
  detail::registry_unknown(kind_, name, names());
}

}  // namespace ccfr
