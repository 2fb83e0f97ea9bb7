#include "ccfr/core/registry.hpp"

#include <cctype>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "ccfr/core/error.hpp"

namespace ccfr {

namespace {
std::string fmt_number(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

std::string show(const ParamValue& v) {
  return std::visit(
      [](const auto& x) -> std::string {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, bool>)
          return x ? "true" : "false";
        else if constexpr (std::is_same_v<T, std::string>)
          return "'" + x + "'";
        else if constexpr (std::is_same_v<T, double>)
          return fmt_number(x);
        else
          return std::to_string(x);
      },
      v);
}

}  // namespace

ParamSpec ParamSpec::number(std::string key, double def, std::string doc, double min, double max, bool min_open,
                            bool max_open) {
  ParamSpec s;
  s.key = std::move(key);
  s.type = ParamType::number;
  s.default_value = def;
  s.doc = std::move(doc);
  s.min = min, s.max = max, s.min_open = min_open, s.max_open = max_open;
  return s;
}

ParamSpec ParamSpec::integer(std::string key, long long def, std::string doc, long long min, long long max) {
  ParamSpec s;
  s.key = std::move(key);
  s.type = ParamType::integer;
  s.default_value = def;
  s.doc = std::move(doc);
  if (min != std::numeric_limits<long long>::min()) s.min = static_cast<double>(min);
  if (max != std::numeric_limits<long long>::max()) s.max = static_cast<double>(max);
  return s;
}

ParamSpec ParamSpec::boolean(std::string key, bool def, std::string doc) {
  ParamSpec s;
  s.key = std::move(key);
  s.type = ParamType::boolean;
  s.default_value = def;
  s.doc = std::move(doc);
  return s;
}

ParamSpec ParamSpec::choice(std::string key, std::string def, std::vector<std::string> choices, std::string doc) {
  ParamSpec s;
  s.key = std::move(key);
  s.type = ParamType::choice;
  s.default_value = std::move(def);
  s.choices = std::move(choices);
  s.doc = std::move(doc);
  return s;
}

std::string ParamSpec::describe_range() const {
  const bool lo = std::isfinite(min), hi = std::isfinite(max);
  if (lo && hi)
    return std::string("in ") + (min_open ? "(" : "[") + fmt_number(min) + ", " + fmt_number(max) +
           (max_open ? ")" : "]");
  if (lo) return (min_open ? "> " : ">= ") + fmt_number(min);
  if (hi) return (max_open ? "< " : "<= ") + fmt_number(max);
  return {};
}

std::string ParamSpec::check(const ParamValue& v) const {
  double x = 0.0;
  switch (type) {
    case ParamType::boolean:
      return std::holds_alternative<bool>(v) ? std::string() : "must be a boolean (true or false)";
    case ParamType::choice: {
      const auto* s = std::get_if<std::string>(&v);
      std::string list;
      for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
      if (!s) return "must be one of: " + list;
      for (const auto& c : choices)
        if (c == *s) return {};
      return "must be one of: " + list + "; got '" + *s + "'";
    }
    case ParamType::integer:
      if (!std::holds_alternative<long long>(v)) return "must be an integer";
      x = static_cast<double>(std::get<long long>(v));
      break;
    case ParamType::number:
      if (const auto* d = std::get_if<double>(&v))
        x = *d;
      else if (const auto* i = std::get_if<long long>(&v))
        x = static_cast<double>(*i);
      else
        return "must be a number";
      if (!std::isfinite(x)) return "must be finite";
      break;
  }
  const bool ok = (min_open ? x > min : x >= min) && (max_open ? x < max : x <= max);
  return ok ? std::string() : "must be " + describe_range() + "; got " + show(v);
}

const ParamValue& ParamValues::at(const std::string& key) const {
  auto it = values_.find(key);
  if (it == values_.end()) throw std::logic_error("component parameter '" + key + "' is not set");
  return it->second;
}

double ParamValues::number(const std::string& key) const {
  const auto& v = at(key);
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* i = std::get_if<long long>(&v)) return static_cast<double>(*i);
  throw std::logic_error("component parameter '" + key + "' is not a number");
}

long long ParamValues::integer(const std::string& key) const {
  if (const auto* i = std::get_if<long long>(&at(key))) return *i;
  throw std::logic_error("component parameter '" + key + "' is not an integer");
}

bool ParamValues::boolean(const std::string& key) const {
  if (const auto* b = std::get_if<bool>(&at(key))) return *b;
  throw std::logic_error("component parameter '" + key + "' is not a boolean");
}

const std::string& ParamValues::choice(const std::string& key) const {
  if (const auto* s = std::get_if<std::string>(&at(key))) return *s;
  throw std::logic_error("component parameter '" + key + "' is not a string");
}

ParamValues complete_params(std::span<const ParamSpec> specs, const ParamValues& given, std::string_view where) {
  ParamValues out;
  for (const auto& [key, value] : given.values()) {
    const ParamSpec* spec = nullptr;
    for (const auto& s : specs)
      if (s.key == key) spec = &s;
    if (!spec) {
      std::string list;
      for (const auto& s : specs) list += (list.empty() ? "" : ", ") + s.key;
      throw Error(std::string(where) + " has no parameter '" + key + "'" +
                  (list.empty() ? std::string("; it takes none") : "; its parameters: " + list));
    }
    const std::string why = spec->check(value);
    if (!why.empty()) throw Error(std::string(where) + ": parameter '" + key + "' " + why);
    // Integers given for a number are stored as numbers, so factories read one type.
    if (spec->type == ParamType::number && std::holds_alternative<long long>(value))
      out.set(key, static_cast<double>(std::get<long long>(value)));
    else
      out.set(key, value);
  }
  for (const auto& s : specs)
    if (!out.has(s.key)) out.set(s.key, s.default_value);
  return out;
}

namespace detail {

void registry_unknown(const std::string& kind, std::string_view name, const std::vector<std::string>& names) {
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  throw Error("unknown " + kind + " '" + std::string(name) + "'; available: " + list);
}

void registry_check_entry(const std::string& kind, const std::string& name, bool has_factory,
                          std::span<const ParamSpec> params, bool taken) {
  const std::string who = kind + " '" + name + "'";
  if (name.empty()) throw Error("cannot register a " + kind + " without a name");
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_'))
      throw Error("cannot register " + who + ": names use letters, digits and '_' (they are scene-file keys)");
  if (taken) throw Error("cannot register " + who + ": the name is taken");
  if (!has_factory) throw Error("cannot register " + who + " without a factory");
  std::set<std::string> keys;
  for (const auto& p : params) {
    if (p.key.empty() || !keys.insert(p.key).second)
      throw Error("cannot register " + who + ": parameter key '" + p.key + "' is empty or repeated");
    const std::string why = p.check(p.default_value);
    if (!why.empty()) throw Error("cannot register " + who + ": the default of '" + p.key + "' " + why);
  }
}

}  // namespace detail

}  // namespace ccfr
