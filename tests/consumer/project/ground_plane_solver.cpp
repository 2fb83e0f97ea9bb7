// A contact solver defined outside ccfr: one file, registered by the static object at its end.
// `ground_plane` keeps every movable vertex at least ξ above the horizontal plane y = level and
// removes the fraction `friction` of the tangential step of a vertex it pushes.
#include <ccfr/core/registry.hpp>
#include <ccfr/solvers/contact_solver.hpp>

#include <algorithm>
#include <memory>

namespace {

class GroundPlaneSolver final : public ccfr::ContactSolver {
 public:
  GroundPlaneSolver(double level, double friction) : level_(level), friction_(friction) {}
  std::string_view name() const override { return "ground_plane"; }
  ccfr::SolveResult resolve(ccfr::Positions& x, const ccfr::Positions& anchor, const ccfr::SimState& state,
                            ccfr::StepContext& ctx) override {
    const double floor = level_ + ctx.params.contact.offset;
    ccfr::SolveResult r;
    for (size_t i = 0; i < x.size(); ++i) {
      if (state.inv_mass[i] == 0.0 || x[i].y() >= floor) continue;
      ++r.violations_detected;
      ++r.contact_vertices;
      x[i].y() = floor;
      // Tangential step since the anchor, reduced by the friction fraction.
      x[i].x() = anchor[i].x() + (1.0 - friction_) * (x[i].x() - anchor[i].x());
      x[i].z() = anchor[i].z() + (1.0 - friction_) * (x[i].z() - anchor[i].z());
    }
    return r;
  }

 private:
  double level_, friction_;
};

const ccfr::Registration<ccfr::ContactSolverRegistry> kRegistration(
    ccfr::contact_solvers(),
    {"ground_plane",
     "keeps movable vertices xi above the plane y = level (a downstream example)",
     {ccfr::ParamSpec::number("level", 0.0, "height of the ground plane (m)", -1e4, 1e4),
      ccfr::ParamSpec::number("friction", 0.0, "fraction of the tangential step removed on contact", 0.0, 1.0)},
     [](const ccfr::ParamValues& p) {
       return std::make_unique<GroundPlaneSolver>(p.number("level"), p.number("friction"));
     }});

}  // namespace
