/// @file halting_causes.cpp
/// Measurement tool for docs/results.md ("Halting"): runs a scene under a `ccfr` solver whose
/// Plesník projector is wrapped, and classifies every halt (a projection that fell back to the
/// anchor) by what an independent solver says about the same region:
///  - `exact_at_anchor`: the exact Euclidean projection lies within ε of the anchor (the region
///    leaves no room in the direction of motion: halting there loses less than ε);
///  - `budget`: Plesník converges with more outer passes (16), not within max_iterations;
///  - `cycle`: Plesník does not converge even with 64 passes, while the exact projection moves
///    the vertex farther than ε (the equality projection cycles between plane subsets);
///  - `empty`: the exact projector finds no point (cannot happen with a feasible anchor).
/// Attributes counted over all halts: opposing violated planes (n_i·n_j < -0.5, a vertex squeezed
/// between two sides), anchors on a plane (d_k < 1e-3 ξ), and nearly parallel planes.
/// It also prints the per-frame distinct counts of stats.csv's *_distinct columns.
///
///   build/bench/halting_causes CONFIG FRAMES [key.path=value ...]
///   (contact.ccfr_diagnosed.exact_fallback=false: Plesník as in the paper; HALTING_DUMP=N prints
///   the first N classified regions to stderr)
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <vector>

#include "ccfr/feasibility/exact_projector.hpp"
#include "ccfr/feasibility/plesnik.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/region_projection_solver.hpp"
#include "ccfr/solvers/simulation.hpp"

namespace {
using namespace ccfr;

struct Tally {
  std::mutex mutex;
  long calls = 0, halted = 0, fell_back = 0, rescued = 0, still_halted = 0;
  long exact_at_anchor = 0, budget = 0, cycle = 0, empty = 0;
  long with_opposing = 0, with_anchor_on_plane = 0, with_parallel = 0;
  long planes_sum = 0, violated_sum = 0, max_planes = 0;
  double gain_sum = 0.0;  ///< |exact point - anchor| / ξ summed over the halts the exact projection moves
  long gain_n = 0;
};
Tally tally;
double offset_xi = 1.0;  // ξ of the scene, set before the run
long dump_cases = 0;     // HALTING_DUMP: print this many halting regions to stderr

class DiagnosedPlesnik final : public Projector {
 public:
  explicit DiagnosedPlesnik(const ProjectorParams& p) : p_(p), inner_(p) {}
  std::string_view name() const override { return "plesnik_diagnosed"; }
  ProjectResult project(const Vec3& a, const Vec3& x, std::span<const HalfSpace> planes) const override {
    const ProjectResult r = inner_.project(a, x, planes);
    // A rescue (exact_fallback) is a halt the exact projection avoided: classified the same way.
    if (r.status != ProjectStatus::halted && !r.rescued) {
      if (r.status != ProjectStatus::feasible) {
        std::lock_guard<std::mutex> lock(tally.mutex);
        ++tally.calls;
        tally.fell_back += r.fell_back;
      }
      return r;
    }
    const Vec3 q = x - a;
    int violated = 0;
    bool opposing = false, on_plane = false, parallel = false;
    for (size_t i = 0; i < planes.size(); ++i) {
      const bool vi = planes[i].n.dot(q) + planes[i].d < -p_.feasibility_tolerance;
      violated += vi;
      on_plane = on_plane || planes[i].d < 1e-3 * offset_xi;
      for (size_t j = i + 1; j < planes.size(); ++j) {
        const double c = planes[i].n.dot(planes[j].n);
        const bool vj = planes[j].n.dot(q) + planes[j].d < -p_.feasibility_tolerance;
        if (vi && vj && c < -0.5) opposing = true;
        if (c > 0.999) parallel = true;
      }
    }
    // The exact projector's answer, retracted by ε toward the anchor as every projector's is.
    const ProjectResult e = ExactProjector(p_).project(a, x, planes);
    int cls;  // 0 at anchor, 1 budget, 2 cycle, 3 empty
    double gain = 0.0;
    if (e.status != ProjectStatus::projected) {
      cls = 3;
    } else if ((gain = (e.x - a).norm()) <= p_.epsilon) {
      cls = 0;
    } else {
      ProjectorParams more = p_;
      more.exact_fallback = false;  // Plesník alone
      more.max_iterations = 16;
      if (PlesnikProjector(more).project(a, x, planes).status == ProjectStatus::projected) {
        cls = 1;
      } else {
        more.max_iterations = 64;
        cls = PlesnikProjector(more).project(a, x, planes).status == ProjectStatus::projected ? 1 : 2;
      }
    }
    std::lock_guard<std::mutex> lock(tally.mutex);
    if (tally.halted < dump_cases) {  // the region as a test would write it (anchor-relative)
      std::fprintf(stderr, "case %ld class %d: q = (%.17g, %.17g, %.17g)\n", tally.halted, cls, q.x(), q.y(), q.z());
      for (const HalfSpace& h : planes)
        std::fprintf(stderr, "  {Vec3(%.17g, %.17g, %.17g), %.17g},\n", h.n.x(), h.n.y(), h.n.z(), h.d);
    }
    ++tally.calls;
    ++tally.halted;
    tally.fell_back += r.fell_back;
    tally.rescued += r.rescued;
    tally.still_halted += r.status == ProjectStatus::halted;
    (cls == 0 ? tally.exact_at_anchor : cls == 1 ? tally.budget : cls == 2 ? tally.cycle : tally.empty) += 1;
    tally.with_opposing += opposing;
    tally.with_anchor_on_plane += on_plane;
    tally.with_parallel += parallel;
    tally.planes_sum += static_cast<long>(planes.size());
    tally.violated_sum += violated;
    tally.max_planes = std::max<long>(tally.max_planes, static_cast<long>(planes.size()));
    if (cls != 0 && cls != 3) tally.gain_sum += gain / offset_xi, ++tally.gain_n;
    return r;
  }

 private:
  ProjectorParams p_;
  PlesnikProjector inner_;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s CONFIG FRAMES [key.path=value ...]\n", argv[0]);
    return 2;
  }
  try {
    projectors().add({"plesnik_diagnosed", "Plesník with every halt classified (bench/halting_causes)",
                      projectors().at("plesnik").params,
                      [](const ParamValues&, const ProjectorParams& p) -> std::unique_ptr<Projector> {
                        return std::make_unique<DiagnosedPlesnik>(p);
                      }});
    contact_solvers().add(
        {"ccfr_diagnosed", "ccfr with classified halts", projectors().at("plesnik").params, [](const ParamValues& v) {
           return std::make_unique<RegionProjectionSolver>("ccfr_diagnosed", "plesnik_diagnosed", v);
         }});
    std::vector<std::string> overrides{"contact.solver=ccfr_diagnosed", "time.frames=" + std::string(argv[2])};
    for (int i = 3; i < argc; ++i) overrides.emplace_back(argv[i]);
    io::LoadedScene loaded = io::load_scene(argv[1], overrides);
    offset_xi = loaded.scene.params.contact.offset;
    if (const char* d = std::getenv("HALTING_DUMP")) dump_cases = std::atol(d);
    const int frames = loaded.scene.params.time.frames;
    Simulation sim(std::move(loaded.scene));
    long halted_sum = 0, contact_sum = 0, hd_sum = 0, cd_sum = 0;
    double worst_frame = 0.0, worst_pass = 0.0;
    int worst_frame_at = 0;
    std::printf("frame,halted_vertices,contact_vertices,halted_vertices_distinct,contact_vertices_distinct\n");
    for (int f = 0; f < frames; ++f) {
      const FrameStats s = sim.step_frame();
      std::printf("%d,%d,%d,%d,%d\n", s.frame, s.halted_vertices, s.contact_vertices, s.halted_vertices_distinct,
                  s.contact_vertices_distinct);
      halted_sum += s.halted_vertices;
      contact_sum += s.contact_vertices;
      hd_sum += s.halted_vertices_distinct;
      cd_sum += s.contact_vertices_distinct;
      if (s.contact_vertices_distinct > 0) {
        const double ratio = double(s.halted_vertices_distinct) / s.contact_vertices_distinct;
        if (ratio > worst_frame) worst_frame = ratio, worst_frame_at = s.frame;
      }
      if (s.contact_vertices > 0) worst_pass = std::max(worst_pass, double(s.halted_vertices) / s.contact_vertices);
    }
    const Tally& t = tally;
    std::printf("# summary frames=%d vertices=%d\n", frames, sim.topology().num_vertices());
    std::printf("# per frame, distinct: max %.3f %% of contact vertices (frame %d), mean %.3f %%\n",
                100.0 * worst_frame, worst_frame_at, cd_sum > 0 ? 100.0 * hd_sum / cd_sum : 0.0);
    std::printf("# per pass (sums): max %.3f %% of contact vertices, mean %.3f %%\n", 100.0 * worst_pass,
                contact_sum > 0 ? 100.0 * halted_sum / contact_sum : 0.0);
    std::printf(
        "# projections %ld, Plesnik not converged %ld (%.3f %%): rescued by the exact projection %ld, "
        "halted %ld; farther than the anchor, replaced by exact %ld\n",
        t.calls, t.halted, t.calls ? 100.0 * t.halted / t.calls : 0.0, t.rescued, t.still_halted, t.fell_back);
    std::printf("# halt causes: exact_at_anchor %ld, budget %ld, cycle %ld, empty %ld\n", t.exact_at_anchor, t.budget,
                t.cycle, t.empty);
    std::printf("# halts with opposing violated planes %ld, anchor on a plane %ld, parallel planes %ld\n",
                t.with_opposing, t.with_anchor_on_plane, t.with_parallel);
    std::printf("# planes per halted vertex: mean %.1f (violated %.1f), max %ld; exact gain mean %.4f xi\n",
                t.halted ? double(t.planes_sum) / t.halted : 0.0, t.halted ? double(t.violated_sum) / t.halted : 0.0,
                t.max_planes, t.gain_n ? t.gain_sum / t.gain_n : 0.0);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "halting_causes: %s\n", e.what());
    return 1;
  }
  return 0;
}
