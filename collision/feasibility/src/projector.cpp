#include "ccfr/feasibility/projector.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/feasibility/exact_projector.hpp"
#include "ccfr/feasibility/plesnik.hpp"
#include "ccfr/feasibility/successive_projection.hpp"

namespace ccfr {

namespace {

/// A vertex counts as remaining outside when a value is below this (or NaN) after projection.
constexpr double kRemainingSlack = 1e-9;

}  // namespace

std::string_view to_string(ProjectStatus status) {
  switch (status) {
    case ProjectStatus::feasible:
      return "feasible";
    case ProjectStatus::projected:
      return "projected";
    case ProjectStatus::halted:
      return "halted";
    case ProjectStatus::infeasible:
      return "infeasible";
  }
  return "unknown";
}

void validate(const ProjectorParams& p) {
  auto bad = [](const char* field, const char* rule) {
    throw Error(std::string("projector parameter '") + field + "' must be " + rule);
  };
  if (!(p.epsilon >= 0.0) || !std::isfinite(p.epsilon)) bad("epsilon", "finite and >= 0");
  if (p.max_iterations < 1) bad("max_iterations", ">= 1");
  if (!(p.redundancy_tolerance >= 0.0) || !std::isfinite(p.redundancy_tolerance))
    bad("redundancy_tolerance", "finite and >= 0");
  if (!(p.feasibility_tolerance >= 0.0) || !std::isfinite(p.feasibility_tolerance))
    bad("feasibility_tolerance", "finite and >= 0");
  if (p.sweeps < 1) bad("sweeps", ">= 1");
}

ProjectorRegistry& projectors() {
  static ProjectorRegistry registry = [] {
    const ProjectorParams d;  // the specs' defaults are the struct's: one owner
    ProjectorRegistry r("projector");
    r.add({"plesnik",
           "Plesník's finite projection onto the violated half-spaces, re-check, the exact projection where the passes "
           "do not converge, halting fallback (the paper halts at once)",
           {ParamSpec::integer(
                "max_iterations", d.max_iterations,
                "projection passes (project, re-check every plane) before the exact projection (exact_fallback) or a "
                "halt at the anchor",
                1),
            ParamSpec::number("redundancy_tolerance", d.redundancy_tolerance,
                              "a new plane whose equation is dependent on the stored ones within this is skipped", 0.0),
            ParamSpec::boolean("exact_fallback", d.exact_fallback,
                               "when the passes do not converge, take the exact projection before halting (false: "
                               "halt at once, as the paper)")},
           [](const ParamValues&, const ProjectorParams& p) -> std::unique_ptr<Projector> {
             return std::make_unique<PlesnikProjector>(p);
           }});
    r.add({"successive_projection",
           "cyclic projection onto one half-space at a time (related work), no fallback",
           {ParamSpec::integer("sweeps", d.sweeps, "cyclic sweeps over the half-spaces", 1)},
           [](const ParamValues&, const ProjectorParams& p) -> std::unique_ptr<Projector> {
             return std::make_unique<SuccessiveProjectionProjector>(p);
           }});
    r.add({"exact",
           "the exact Euclidean projection (active set with a dual certificate)",
           {},
           [](const ParamValues&, const ProjectorParams& p) -> std::unique_ptr<Projector> {
             return std::make_unique<ExactProjector>(p);
           }});
    return r;
  }();
  return registry;
}

ProjectorParams apply_projector_params(ProjectorParams base, const ParamValues& values) {
  for (const auto& [key, v] : values.values()) {
    if (key == "max_iterations")
      base.max_iterations = static_cast<int>(values.integer(key));
    else if (key == "redundancy_tolerance")
      base.redundancy_tolerance = values.number(key);
    else if (key == "exact_fallback")
      base.exact_fallback = values.boolean(key);
    else if (key == "sweeps")
      base.sweeps = static_cast<int>(values.integer(key));
    else
      throw Error("projector parameter '" + key + "' does not exist");
  }
  return base;
}

std::unique_ptr<Projector> make_projector(std::string_view name, const ProjectorParams& params) {
  const auto& e = projectors().at(name);
  validate(params);
  return e.make(ParamValues{}, params);
}

std::vector<std::string> projector_names() { return projectors().names(); }

BatchStats& BatchStats::operator+=(const BatchStats& o) {
  violated += o.violated;
  projected += o.projected;
  remaining += o.remaining;
  halted += o.halted;
  infeasible += o.infeasible;
  fallbacks += o.fallbacks;
  rescued += o.rescued;
  iterations += o.iterations;
  return *this;
}

double min_value(const Vec3& x_anchor, const Vec3& x, std::span<const HalfSpace> planes) {
  double lo = std::numeric_limits<double>::infinity();
  for (const auto& h : planes) {
    const double r = h.value(x_anchor, x);
    if (std::isnan(r)) return std::numeric_limits<double>::quiet_NaN();
    lo = std::min(lo, r);
  }
  return lo;
}

bool falls_below(const Vec3& x_anchor, const Vec3& x, std::span<const HalfSpace> planes, double level) {
  const Vec3 q = x - x_anchor;
  // Below the level, or NaN.
  for (const auto& h : planes)
    if (!(h.n.dot(q) + h.d >= level)) return true;
  // No planes: min_value's +infinity.
  return planes.empty() && !(std::numeric_limits<double>::infinity() >= level);
}

ProjectResult unusable_input(const Vec3& x_anchor) {
  ProjectResult res;
  res.x = x_anchor;
  res.status = ProjectStatus::infeasible;
  return res;
}

BatchStats project_all(const Projector& projector, const RegionSet& regions, const Positions& anchor, Positions& x,
                       std::span<const double> inv_mass, std::span<std::uint8_t> halted_marks) {
  const Index n = regions.num_vertices();
  if (static_cast<Index>(anchor.size()) != n || static_cast<Index>(x.size()) != n ||
      (!inv_mass.empty() && static_cast<Index>(inv_mass.size()) != n))
    throw std::invalid_argument("project_all: anchor, x and inv_mass must have one entry per region vertex");

  const Index chunks = default_chunk_count(n);
  std::vector<BatchStats> per_chunk(static_cast<size_t>(std::max<Index>(chunks, 1)));
  parallel_chunks(n, chunks, [&](Index c, Index begin, Index end) {
    BatchStats s;
    std::vector<HalfSpace> buf;  // the gathered planes of one vertex outside its region
    for (Index v = begin; v < end; ++v) {
      if (!inv_mass.empty() && !(inv_mass[v] > 0.0)) continue;
      if (regions.count(v) == 0) continue;
      // Cheap pre-check on the shared records: most vertices are inside their region and skip
      // the gather and the projector.
      if (!regions.falls_below(v, anchor[v], x[v], 0.0)) continue;
      const auto planes = regions.of(v, buf);
      const ProjectResult r = projector.project(anchor[v], x[v], planes);
      if (r.status == ProjectStatus::feasible) continue;  // within the projector's tolerance
      ++s.violated;
      s.iterations += r.iterations;
      if (r.status == ProjectStatus::projected) ++s.projected;
      if (r.status == ProjectStatus::halted) {
        ++s.halted;
        if (!halted_marks.empty()) halted_marks[v] = 1;
      }
      if (r.status == ProjectStatus::infeasible) ++s.infeasible;
      if (r.fell_back) ++s.fallbacks;
      if (r.rescued) ++s.rescued;
      x[v] = r.x;
      // Independent re-check of the output, with a slack above every projector's rounding tolerance.
      if (falls_below(anchor[v], x[v], planes, -kRemainingSlack)) ++s.remaining;
    }
    per_chunk[static_cast<size_t>(c)] = s;
  });
  BatchStats total;
  for (const auto& s : per_chunk) total += s;
  return total;
}

}  // namespace ccfr
