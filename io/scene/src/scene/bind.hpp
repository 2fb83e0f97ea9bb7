#pragma once
// Schema keys bound to the C++ fields they fill: each key is declared once, with its type, its
// default (the field's own default in the parameter struct) and its reader, so the schema that
// validates and documents a section and the code that reads it cannot disagree.
#include <array>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "../schema.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr::io::scene {

/// One mapping between a schema choice's strings and a C++ value (an enum, or a flag): the schema
/// lists `names()` as its choices, the reader maps the resolved string back with `value()`.
template <class E>
struct ChoiceTable {
  std::vector<std::pair<std::string, E>> entries;  ///< in the schema's (documented) order

  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& [n, v] : entries) out.push_back(n);
    return out;
  }
  /// The string of `v`; a value without one is a programming error caught by the choice test.
  const std::string& name(E v) const {
    for (const auto& e : entries)
      if (e.second == v) return e.first;
    throw std::logic_error("a value has no choice string in its table");
  }
  /// The value of a string the schema accepted (resolve() rejected every other one).
  E value(const std::string& s) const {
    for (const auto& e : entries)
      if (e.first == s) return e.second;
    throw std::logic_error("choice '" + s + "' is not in its table");
  }
};

/// The keys of one schema section bound to the fields of `S`.
template <class S>
class Section {
 public:
  /// A key read into `S::*m`: number (double), integer (int), boolean (bool) or vec3 (Vec3); its
  /// default is the field's default in `S{}`.
  template <class T, class M>
  Section& field(std::string key, T M::*m, std::string doc, schema::Range r = {}) {
    static_assert(std::is_base_of_v<M, S>);
    return field_default(std::move(key), m, S{}.*m, std::move(doc), r);
  }
  /// As field(), for the few keys whose file default differs from the struct's (Motion::end holds
  /// for ever in code; a file's motion ends at 1e9 s, a finite bound the schema can range-check).
  template <class T, class M>
  Section& field_default(std::string key, T M::*m, T def, std::string doc, schema::Range r = {}) {
    static_assert(std::is_base_of_v<M, S>);
    schema::NodePtr n;
    if constexpr (std::is_same_v<T, double>)
      n = schema::number(def, std::move(doc), r);
    else if constexpr (std::is_same_v<T, int>)
      n = schema::integer(def, std::move(doc), r);
    else if constexpr (std::is_same_v<T, bool>)
      n = schema::boolean(def, std::move(doc));
    else if constexpr (std::is_same_v<T, Vec3>)
      n = schema::vec3(std::array<double, 3>{def.x(), def.y(), def.z()}, std::move(doc), r);
    else
      static_assert(!sizeof(T), "no schema type for this field");
    return add(std::move(key), std::move(n), [m](S& s, const YAML::Node& v) {
      if constexpr (std::is_same_v<T, Vec3>)
        s.*m = Vec3(v[0].as<double>(), v[1].as<double>(), v[2].as<double>());
      else
        s.*m = v.as<T>();
    });
  }
  /// A choice read through its table; the default is the field's default in `S{}`.
  template <class E, class M>
  Section& choice(std::string key, E M::*m, const ChoiceTable<E>& table, std::string doc) {
    static_assert(std::is_base_of_v<M, S>);
    const ChoiceTable<E>* t = &table;  // tables are static: they outlive every schema
    return add(std::move(key),
               schema::choice(
                   t->name(S{}.*m), [t] { return t->names(); }, std::move(doc)),
               [m, t](S& s, const YAML::Node& v) { s.*m = t->value(v.as<std::string>()); });
  }
  /// A choice among names kept as a string (registered components: their list can grow at run time).
  template <class M>
  Section& name(std::string key, std::string M::*m, std::function<std::vector<std::string>()> names, std::string doc) {
    static_assert(std::is_base_of_v<M, S>);
    return add(std::move(key), schema::choice(S{}.*m, std::move(names), std::move(doc)),
               [m](S& s, const YAML::Node& v) { s.*m = v.as<std::string>(); });
  }
  /// A nested map whose keys fill fields of the same struct (contact.friction.static, ...).
  Section& map(std::string key, std::string doc, Section nested) {
    auto fields = nested.fields();
    return add(std::move(key), schema::map(std::move(doc), std::move(fields)),
               [nested = std::move(nested)](S& s, const YAML::Node& v) { nested.read(s, v); });
  }
  /// A key the section's reader handles itself (a list checked with context, a component's
  /// parameters): declared here so the schema keeps its place in the section.
  Section& other(std::string key, schema::NodePtr node) { return add(std::move(key), std::move(node), nullptr); }

  std::vector<schema::Field> fields() const {
    std::vector<schema::Field> out;
    for (const auto& b : bound_) out.push_back({b.key, b.node});
    return out;
  }
  /// Fills the bound fields of `s` from the resolved section (every key present: defaults filled).
  void read(S& s, const YAML::Node& section) const {
    for (const auto& b : bound_)
      if (b.read) b.read(s, section[b.key]);
  }

 private:
  struct Bound {
    std::string key;
    schema::NodePtr node;
    std::function<void(S&, const YAML::Node&)> read;  ///< null: read by the section's own code
  };
  Section& add(std::string key, schema::NodePtr node, std::function<void(S&, const YAML::Node&)> read) {
    bound_.push_back({std::move(key), std::move(node), std::move(read)});
    return *this;
  }
  std::vector<Bound> bound_;
};

}  // namespace ccfr::io::scene
