// Why a substep ended with pairs inside their offsets, and what contact.on_violation does about it:
// the StopReport (close pairs, holders, cause, advice) and the stop's message.
#include <algorithm>
#include <map>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/solvers/simulation.hpp"

namespace ccfr {

namespace {

/// What holds the reported pairs' movable vertices, and the fastest scripted vertex among them.
struct Holders {
  std::vector<Index> objects;  ///< objects that cannot move, across a close pair from a reported vertex
  double fastest = 0.0;        ///< largest scripted step (m per substep piece) among them and the pairs
  std::string fastest_object;  ///< its object; empty when nothing scripted moves
};

/// Every object that cannot move and is on the other side of one of `close`'s pairs touching a
/// movable vertex of the reported pairs (the first three of `close`), and the fastest scripted one.
Holders find_holders(const Topology& topo, const SimState& st, std::span<const Vec3> kinematic_step,
                     const std::vector<ContactSolver::ClosePair>& close, StopReport& rep) {
  Holders h;
  std::vector<std::uint8_t> reported(static_cast<size_t>(st.size()), 0);
  for (size_t i = 0; i < close.size() && i < 3; ++i)
    for (int k = 0; k < close[i].size; ++k) reported[static_cast<size_t>(close[i].v[static_cast<size_t>(k)])] = 1;
  for (const auto& c : close) {
    bool touches = false;
    for (int k = 0; k < c.size; ++k)
      touches = touches || (reported[static_cast<size_t>(c.v[static_cast<size_t>(k)])] &&
                            st.inv_mass[c.v[static_cast<size_t>(k)]] > 0.0);
    if (!touches) continue;
    for (int k = 0; k < c.size; ++k) {
      const Index v = c.v[static_cast<size_t>(k)];
      if (st.inv_mass[v] > 0.0) continue;
      const Index oi = topo.vertex_object[v];
      if (std::find(h.objects.begin(), h.objects.end(), oi) == h.objects.end()) h.objects.push_back(oi);
    }
  }
  for (const auto& pr : rep.pairs)
    for (const auto* side : {&pr.a, &pr.b})
      for (const auto& x : *side)
        if (x.fixed && x.scripted_step > h.fastest) h.fastest = x.scripted_step, h.fastest_object = x.object;
  for (Index oi : h.objects) {
    const auto& o = topo.objects[oi];
    double step = 0.0;
    for (Index v = o.vertex_begin; v < o.vertex_end && static_cast<size_t>(v) < kinematic_step.size(); ++v)
      if (!(st.inv_mass[v] > 0.0)) step = std::max(step, kinematic_step[v].norm());
    if (step > h.fastest) h.fastest = step, h.fastest_object = o.name;
    rep.held_by.push_back(ccfr::format("'{}' ({}{})", o.name, to_string(o.kind),
                                       step > 0.0
                                           ? ccfr::format(", scripted, {:.3g} m per substep piece", step)
                                           : std::string(o.kind == ObjectKind::obstacle ? ", fixed" : ", pinned")));
  }
  return h;
}

/// The stop's cause (StopReport::cause), most specific first.
std::string stop_cause(const StopReport& rep) {
  bool fixed_pair = false, empty = false, halted_any = false;
  for (const auto& pr : rep.pairs) {
    bool a_fixed = true, b_fixed = true;
    for (const auto& x : pr.a) {
      a_fixed = a_fixed && x.fixed;
      empty = empty || x.region_empty.value_or(false);
      halted_any = halted_any || x.halted;
    }
    for (const auto& x : pr.b) {
      b_fixed = b_fixed && x.fixed;
      empty = empty || x.region_empty.value_or(false);
      halted_any = halted_any || x.halted;
    }
    fixed_pair = fixed_pair || (a_fixed && b_fixed);
  }
  const bool ran_out = rep.held_back > 0 && rep.iterations >= rep.iteration_bound;
  return fixed_pair   ? "fixed_pair"
         : empty      ? "region_empty"
         : ran_out    ? "iterations_ran_out"
         : halted_any ? "halted"
                      : "unresolved";
}

/// What a user can change for this cause (StopReport::suggestions), most useful first.
std::vector<std::string> stop_suggestions(const StopReport& rep, const SimulationParams& p, const Holders& h) {
  std::vector<std::string> out;
  const double xi = p.contact.offset, r = p.contact.radius;
  if (!h.fastest_object.empty())
    out.push_back(
        ccfr::format("slow the scripted motion of '{}' ({:.3g} m per substep piece against "
                     "r = {:.3g}) or stop it before it closes the gap",
                     h.fastest_object, h.fastest, r));
  if (rep.cause == "iterations_ran_out" || !h.fastest_object.empty())
    out.push_back(ccfr::format("raise time.substeps (now {}) for smaller steps", p.time.substeps));
  if (rep.cause == "iterations_ran_out")
    out.push_back(
        ccfr::format("raise time.max_iterations (now {}: all {} outer iterations ran with {} "
                     "vertices still held back)",
                     p.time.max_iterations, rep.iterations, rep.held_back));
  if (rep.cause == "region_empty" || h.objects.size() >= 2 || rep.cause == "fixed_pair")
    out.push_back(
        ccfr::format("give the squeezed objects room: a gap narrower than their offsets "
                     "(contact.offset = {:.3g} per pair) cannot hold them; lower the offset, or "
                     "move the objects that cannot move apart",
                     xi));
  if (rep.cause == "halted" || rep.cause == "unresolved")
    out.push_back(
        ccfr::format("raise time.substeps (now {}) or contact.radius (r = {:.3g}) so that "
                     "vertices can get away in time",
                     p.time.substeps, r));
  out.push_back(
      "contact.on_violation: warn continues past it (the frames then keep the violations; ccfr audit reports them)");
  return out;
}

/// One side of a reported pair: "'cloth' vertices 3, 4 (pinned, halted)".
std::string describe_side(const std::vector<StopReport::Vertex>& side) {
  if (side.empty()) return "?";
  std::string s = "'" + side.front().object + "' vert" + (side.size() > 1 ? "ices " : "ex ");
  for (size_t k = 0; k < side.size(); ++k) s += (k ? ", " : "") + std::to_string(side[k].local);
  std::vector<std::string> notes;
  const auto& f = side.front();
  if (f.scripted_step > 0.0)
    notes.push_back("scripted");
  else if (f.fixed)
    notes.push_back(f.kind == "obstacle" ? "obstacle" : "pinned");
  bool halted = false, held = false, empty = false, nonempty = false;
  for (const auto& x : side) {
    halted = halted || x.halted;
    held = held || x.held_back;
    empty = empty || x.region_empty.value_or(false);
    nonempty = nonempty || (x.region_empty.has_value() && !*x.region_empty);
  }
  if (halted) notes.push_back("halted");
  if (held) notes.push_back("held back by the step bound");
  if (empty) notes.push_back("region empty");
  if (nonempty && !empty) notes.push_back("region not empty");
  if (!notes.empty()) {
    s += " (";
    for (size_t k = 0; k < notes.size(); ++k) s += (k ? ", " : "") + notes[k];
    s += ")";
  }
  return s;
}

/// The stop's message: the count, the reported pairs, the cause, the holders and the advice.
std::string stop_message(const StopReport& rep, Index remaining, const std::string& example) {
  std::string what = std::to_string(remaining) + " violation(s) remain at the end of substep " +
                     std::to_string(rep.substep) + " under contact solver '" + rep.solver +
                     "' (pairs closer than their offset, or a deformed rigid body)";
  if (rep.pairs.empty()) {
    if (!example.empty()) what += "; e.g. a " + example;
  } else {
    what += "; " + std::string(rep.pairs.size() < static_cast<size_t>(remaining) ? "among them " : "");
    for (size_t i = 0; i < rep.pairs.size(); ++i) {
      const auto& pr = rep.pairs[i];
      what += (i ? "; " : "") + pr.kind + " " + describe_side(pr.a) + " - " + describe_side(pr.b) +
              ccfr::format(" at {:.6g} ({:.4f} of its offset {:.6g})", pr.distance, pr.distance / pr.offset, pr.offset);
    }
  }
  static const std::map<std::string, std::string> kCause = {
      {"fixed_pair",
       "neither side of a pair can move (obstacles, pinned or scripted vertices): the scene drives "
       "them into each other"},
      {"region_empty",
       "a squeeze: the region of a movable vertex is empty (certified by the exact projection), "
       "no position keeps it its offset from everything around it"},
      {"iterations_ran_out", "the outer iterations ran out"},
      {"halted", "a vertex of the pair halted (its projection failed and it stayed at its anchor)"},
      {"unresolved",
       "the regions were not empty and no vertex was left held back by r, yet the pair ended inside its "
       "offset or crossed"}};
  what += ". Cause: " + kCause.at(rep.cause) +
          ccfr::format(" ({} of {} outer iterations ran, {} vertices held back at the end{})", rep.iterations,
                       rep.iteration_bound, rep.held_back,
                       rep.halvings > 0 ? ccfr::format("; the substep was solved again in {} pieces, and the "
                                                       "steps below are those of a piece",
                                                       1 << rep.halvings)
                                        : std::string());
  if (!rep.held_by.empty()) {
    what += ". Held by: ";
    for (size_t i = 0; i < rep.held_by.size(); ++i) what += (i ? ", " : "") + rep.held_by[i];
  }
  what += ". What to change: ";
  for (size_t i = 0; i < rep.suggestions.size(); ++i) what += (i ? "; " : "") + rep.suggestions[i];
  return what;
}

}  // namespace

StopReport::Vertex Simulation::stop_vertex(Index v, std::span<const std::uint8_t> halted) const {
  const auto& st = scene_.state;
  StopReport::Vertex x;
  const auto& o = scene_.topo.object_of_vertex(v);
  x.object = o.name;
  x.kind = std::string(to_string(o.kind));
  x.local = v - o.vertex_begin;
  x.fixed = !(st.inv_mass[v] > 0.0);
  if (x.fixed && static_cast<size_t>(v) < kinematic_step_.size()) x.scripted_step = kinematic_step_[v].norm();
  x.halted = static_cast<size_t>(v) < halted.size() && halted[v];
  // held_marks_ also frees the neighbourhood of violated pairs for the next pass: not a hold-back.
  x.held_back = static_cast<size_t>(v) < held_marks_.size() && held_marks_[v] &&
                !(static_cast<size_t>(v) < violated_marks_.size() && violated_marks_[v]);
  if (!x.fixed && static_cast<size_t>(v) < solve_.size()) x.region_empty = contact_->region_empty(v, solve_);
  return x;
}

StopReport Simulation::diagnose_stop(Index remaining, int substep_index, int iterations, Index held_back,
                                     const FrameStats& fs) const {
  const auto& p = scene_.params;
  StopReport rep;
  rep.frame = frame_ + 1;
  rep.substep = substep_index + 1;
  rep.remaining = remaining;
  rep.solver = std::string(contact_->name());
  rep.iterations = iterations;
  rep.halvings = halvings_;
  rep.iteration_bound = p.time.iteration_bound();
  rep.held_back = held_back;
  rep.stats = fs;
  rep.stats.frame = frame_ + 1;
  rep.stats.sim_time = scene_.state.time;
  rep.stats.violations_remaining = std::max(rep.stats.violations_remaining, remaining);
  std::vector<std::int32_t> half_spaces;
  std::vector<double> distance;
  std::vector<std::uint8_t> halted;
  contact_->vertex_diagnostics(half_spaces, distance, halted);
  // anchor_ holds where the substep ends, solve_ the last pass's anchors (where its regions were built).
  const auto close = contact_->close_pairs(anchor_, 1.0 - p.debug.audit_tolerance, 64);
  static constexpr const char* kKind[] = {"vertex-face", "edge-edge", "vertex-edge", "vertex-vertex"};
  for (size_t i = 0; i < close.size() && i < 3; ++i) {
    const auto& c = close[i];
    StopReport::Pair pr;
    pr.kind = kKind[std::clamp(c.kind, 0, 3)];
    for (int k = 0; k < c.size; ++k)
      (k < c.side_a ? pr.a : pr.b).push_back(stop_vertex(c.v[static_cast<size_t>(k)], halted));
    pr.distance = c.distance;
    pr.offset = c.offset;
    rep.pairs.push_back(std::move(pr));
  }
  const Holders holders = find_holders(scene_.topo, scene_.state, kinematic_step_, close, rep);
  rep.cause = stop_cause(rep);
  rep.suggestions = stop_suggestions(rep, p, holders);
  return rep;
}

bool Simulation::stops_on_violation() const {
  const auto policy = scene_.params.contact.on_violation;
  return policy == ViolationPolicy::error ||
         (policy == ViolationPolicy::automatic && contact_->guarantees_separation());
}

void Simulation::check_violations(Index remaining, int substep_index, int iterations, Index held_back,
                                  const FrameStats& fs) {
  if (remaining <= 0) return;
  if (!stops_on_violation()) {
    if (!warned_violation_) {
      const std::string example = contact_->last_violation();
      log::error(
          "frame {}: {} violation(s) remain at the end of substep {} under contact solver '{}'{}; continuing "
          "(contact.on_violation: warn)",
          frame_ + 1, remaining, substep_index + 1, contact_->name(),
          example.empty() ? std::string() : "; e.g. a " + example);
    }
    warned_violation_ = true;
    return;
  }
  StopReport rep = diagnose_stop(remaining, substep_index, iterations, held_back, fs);
  std::string what = stop_message(rep, remaining, rep.pairs.empty() ? contact_->last_violation() : std::string());
  stop_ = std::move(rep);
  throw GuaranteeError(frame_ + 1, what + "; stopping before the frame is written");
}

}  // namespace ccfr
