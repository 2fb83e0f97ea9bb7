// contact.adaptive_reach in the substep loop: the setting's checks and each pass's per-vertex
// reach (adaptive_vertex_reach, step_bound.hpp; docs/feasibility.md, "Adaptive reach"), and
// contact.momentum's last pass, which takes the rest of a step longer than r (reach_long_steps).
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "ccfr/solvers/step_bound.hpp"

namespace ccfr {

void Simulation::init_adaptive_reach() {
  const auto& params = scene_.params;
  // contact.momentum: the last pass of a substep takes the rest of a step longer than r.
  follow_steps_ = params.contact.momentum && contact_->takes_vertex_reach();
  // contact.free_islands: the group carry and the islands' momentum, under the region-projection solvers (the
  // baselines keep their own response).
  free_islands_ = params.contact.free_islands && contact_->takes_vertex_reach();
  if (params.contact.adaptive_reach > 0.0) {
    if (params.collision.reuse_skin > 0.0)
      throw Error(
          ccfr::format("contact.adaptive_reach: {} cannot be combined with collision.reuse_skin = {} (the kept "
                       "list is built at the uniform reach 2r + xi); set one of them to 0",
                       params.contact.adaptive_reach, params.collision.reuse_skin));
    if (!contact_->takes_vertex_reach())
      log::warn(
          "contact.adaptive_reach: contact solver '{}' bounds every vertex by the uniform r; the setting applies "
          "to the region-projection solvers only",
          contact_->name());
    else
      adaptive_reach_ = true;
  }
  if (!adaptive_reach_ && !follow_steps_) return;
  // A rigid body's pose solve bounds its vertices by r as a whole.
  const auto& topo = scene_.topo;
  reach_full_.assign(static_cast<size_t>(topo.num_vertices()), 0);
  for (const auto& o : topo.objects)
    if (o.kind == ObjectKind::rigid)
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) reach_full_[v] = 1;
}

void Simulation::set_vertex_reach(int iteration, bool uniform, bool masked, StepContext& ctx) {
  // A pass after one that left pairs inside their offsets or held a follower at a plane its other
  // side vacates runs at the uniform r (or more in the last pass, below): the vertices that must
  // move there are not all marked.
  const bool adaptive = adaptive_reach_ && !uniform;
  reach_pass_ = false;
  ctx.vertex_reach = {};
  if (!adaptive && !follow_steps_) return;
  const auto& st = scene_.state;
  const auto& cp = scene_.params.contact;
  const size_t nv = static_cast<size_t>(st.size());
  if (adaptive) {
    if (reach_held_.size() != nv) reach_held_.assign(nv, 0);
    // The marks of the pass before: held_marks_ under time.continuation: held_back (which adds the
    // vertices of violated pairs: r for them too), else the step bound's own.
    const std::span<const std::uint8_t> held =
        iteration == 0 ? std::span<const std::uint8_t>() : (held_marks_.empty() ? reach_held_ : held_marks_);
    adaptive_vertex_reach(material_solved_, anchor_, st.inv_mass, reach_full_, held, cp.radius, cp.adaptive_reach,
                          cp.repulsion_range, vertex_reach_);
  } else {
    vertex_reach_.clear();
  }
  // The last pass takes the rest of every step longer than r (contact.momentum); without any, the
  // uniform r.
  const bool last = iteration + 1 >= scene_.params.time.iteration_bound();
  const bool longer = follow_steps_ && last &&
                      reach_long_steps(material_solved_, anchor_, st.inv_mass, reach_full_, cp.radius, vertex_reach_);
  if (!adaptive && !longer) return;
  if (reach_held_.size() != nv) reach_held_.assign(nv, 0);
  // A vertex fixed for this pass only (time.continuation: held_back) stays at its anchor.
  if (masked)
    for (size_t i = 0; i < nv; ++i)
      if (st.inv_mass[i] == 0.0 && inv_mass_saved_[i] != 0.0) vertex_reach_[i] = 0.0;
  reach_pass_ = true;
  ctx.vertex_reach = vertex_reach_;
}

}  // namespace ccfr
