// A downstream material constraint `tether` (docs/extending.md, "A material constraint"): each
// vertex of a material that sets `materials.<name>.tether` stays within `length` of its rest
// position, C = max(0, |x - x̄| - length), as a one-vertex XPBD inequality with `compliance`.
// Registered here; tether.yaml switches it on for a block of particles.
#include <ccfr/core/registry.hpp>
#include <ccfr/solvers/material_constraint.hpp>

#include <cmath>
#include <memory>
#include <vector>

namespace {

class TetherBatch final : public ccfr::ConstraintBatch {
 public:
  std::vector<ccfr::Index> ids;  ///< one vertex per constraint
  std::vector<ccfr::Vec3> anchor;
  std::vector<double> length, compliance, lambda;

  ccfr::Index size() const override { return static_cast<ccfr::Index>(ids.size()); }
  int arity() const override { return 1; }
  std::span<const ccfr::Index> vertex_ids() const override { return ids; }
  void reset_multipliers() override { lambda.assign(lambda.size(), 0.0); }
  void solve_in_order(std::span<const ccfr::Index> order, ccfr::Positions& x, std::span<const double> w,
                      double dt) override {
    for (const ccfr::Index c : order) {
      const ccfr::Index v = ids[c];
      const ccfr::Vec3 d = x[v] - anchor[c];
      const double dist = d.norm();
      // Slack (or a kinematic vertex): nothing to do, and the multiplier of an inequality is released.
      if (!(dist > length[c]) || !(w[v] > 0.0)) {
        lambda[c] = 0.0;
        continue;
      }
      const double alpha = compliance[c] / (dt * dt);
      const double dl = (-(dist - length[c]) - alpha * lambda[c]) / (w[v] + alpha);
      lambda[c] += dl;
      x[v] += (w[v] * dl / dist) * d;
    }
  }
};

const ccfr::Registration<ccfr::MaterialConstraintRegistry> tether(
    ccfr::material_constraints(),
    {"tether",
     "every vertex stays within `length` of its rest position (a downstream example)",
     {ccfr::ParamSpec::number("length", 0.05, "largest distance from the rest position (m)", 0.0),
      ccfr::ParamSpec::number("compliance", 0.0, "XPBD compliance (m/N); 0 is a hard tether", 0.0)},
     [](const ccfr::ParamValues&, const ccfr::MaterialContext& ctx) -> std::unique_ptr<ccfr::ConstraintBatch> {
       auto b = std::make_unique<TetherBatch>();
       for (size_t o = 0; o < ctx.topo.objects.size(); ++o) {
         const ccfr::ParamValues* p = ctx.object_params[o];
         if (!p) continue;  // this object's material does not set `tether`
         const auto& info = ctx.topo.objects[o];
         for (ccfr::Index v = info.vertex_begin; v < info.vertex_end; ++v) {
           b->ids.push_back(v);
           b->anchor.push_back(ctx.state.rest[v]);
           b->length.push_back(p->number("length"));
           b->compliance.push_back(p->number("compliance"));
           b->lambda.push_back(0.0);
         }
       }
       if (b->ids.empty()) return nullptr;
       return b;
     }});

}  // namespace
