#include "ccfr/io/run_recorder.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>

#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/io/checkpoint.hpp"
#include "ccfr/io/formats.hpp"

namespace ccfr::io {

RunMeta make_run_meta(const Simulation& sim, std::string command_line, std::vector<std::string> argv) {
  const SimulationParams& p = sim.scene().params;
  RunMeta meta;
  meta.scene = p.scene_name;
  meta.solver = p.contact.solver;
  meta.broad_phase = p.collision.broad_phase;
  meta.contact = p.contact;  // the ContactModel part of ContactParams: r, ξ, δ, friction
  meta.fps = p.time.fps;
  meta.threads = thread_count();
  meta.command_line = std::move(command_line);
  meta.argv = std::move(argv);
  if (const CollisionDetector* det = sim.contact_solver().collision_detector())
    meta.initial_proximity = det->initial_proximity();
  if (!p.output.formats.empty()) meta.formats = parse_output_formats(p.output.formats);
  meta.every = p.output.every;
  meta.frames = p.output.frames;
  // A run from the scene's start: its state is the initial one the fingerprint is of (a resume
  // sets the checkpoint's).
  if (sim.frames_done() == 0) meta.scene_fingerprint = scene_fingerprint(sim.topology(), sim.scene().state);
  return meta;
}

std::vector<std::uint8_t> audit_object_roles(const Topology& topo, const SimulationParams& params) {
  std::vector<std::uint8_t> roles(topo.objects.size(), 0);
  for (size_t o = 0; o < topo.objects.size() && o < params.objects.size(); ++o) {
    const ObjectParams& op = params.objects[o];
    if (topo.objects[o].kind == ObjectKind::obstacle) {
      // An OBJ sequence (`animation` keys) may deform; keyframes are rigid transforms.
      const bool animated = op.motion.animation && op.motion.animation->rotations.empty();
      roles[o] = static_cast<std::uint8_t>(exact::kScriptedObject | (animated ? 0 : exact::kRigidObject));
    } else if (topo.objects[o].kind == ObjectKind::rigid) {
      roles[o] = static_cast<std::uint8_t>(exact::kRigidObject | (op.pins.empty() ? 0 : exact::kScriptedObject));
    }
  }
  return roles;
}

AuditHook make_audit_hook(const Topology& topo, const Positions& initial, const SimulationParams& params,
                          std::shared_ptr<exact::PenetrationAudit>* audit_out) {
  exact::AuditOptions opt;
  opt.offset = params.contact.offset;
  opt.tolerance = params.debug.audit_tolerance;
  opt.object_roles = audit_object_roles(topo, params);
  if (opt.offset <= 0.0) {
    log::warn("debug.audit needs contact.offset > 0; the audit is off for this run");
    return {};
  }
  auto audit = std::make_shared<exact::PenetrationAudit>(topo, initial, opt);
  if (audit_out) *audit_out = audit;
  return [audit](const Positions& x) {
    const exact::FrameAudit fa = audit->audit_next(x);  // in order: raises the reduced offsets
    if (!fa.clean() && !fa.examples.empty()) log::debug("audit: {}", fa.examples.front().describe());
    return fa.penetrations();
  };
}

RunRecorder::RunRecorder(std::filesystem::path dir, const Simulation& sim, std::string resolved_config_json,
                         RunMeta meta, int last_frame, bool force)
    : sim_(sim),
      writer_(std::move(dir), sim.topology(), std::move(resolved_config_json), std::move(meta), force),
      last_frame_(last_frame) {
  want_fields_ = writer_.wants_fields();
}

RunRecorder::RunRecorder(std::filesystem::path dir, const Simulation& sim, std::string resolved_config_json,
                         RunMeta meta, int last_frame, RunWriter::ResumeAt resume)
    : sim_(sim),
      writer_(std::move(dir), sim.topology(), std::move(resolved_config_json), std::move(meta), resume),
      last_frame_(last_frame),
      resumed_(true) {
  want_fields_ = writer_.wants_fields();
}

void RunRecorder::start() {
  writer_.start();
  if (sim_.scene().params.output.frames && !resumed_) writer_.write_frame(0, sim_.positions(), fields());
}

void RunRecorder::record(const FrameStats& s) {
  const auto& out = sim_.scene().params.output;
  if (out.frames && (s.frame % out.every == 0 || s.frame == last_frame_))
    writer_.write_frame(s.frame, sim_.positions(), fields());
  writer_.write_stats(s);
}

VertexFields RunRecorder::fields() const {
  VertexFields f;
  if (!want_fields_) return f;  // only the VTU frames carry per-vertex fields
  f.velocity = sim_.scene().state.v;
  sim_.contact_solver().vertex_diagnostics(f.half_spaces, f.distance, f.halted);
  return f;
}

namespace {
/// run.json's `stop` (docs/output.md).
std::string stop_json(const StopReport& r) {
  using Json = nlohmann::ordered_json;
  auto vertices = [](const std::vector<StopReport::Vertex>& side) {
    Json a = Json::array();
    for (const auto& x : side) {
      Json v = {{"object", x.object}, {"kind", x.kind},     {"vertex", x.local},
                {"fixed", x.fixed},   {"halted", x.halted}, {"held_back", x.held_back}};
      if (x.scripted_step > 0.0) v["scripted_step"] = x.scripted_step;
      v["region_empty"] = x.region_empty ? Json(*x.region_empty) : Json(nullptr);
      a.push_back(std::move(v));
    }
    return a;
  };
  Json pairs = Json::array();
  for (const auto& p : r.pairs)
    pairs.push_back(
        {{"kind", p.kind}, {"a", vertices(p.a)}, {"b", vertices(p.b)}, {"distance", p.distance}, {"offset", p.offset}});
  Json j = {{"reason", "violations remain"},
            {"frame", r.frame},
            {"substep", r.substep},
            {"remaining", r.remaining},
            {"solver", r.solver},
            {"cause", r.cause},
            {"outer_iterations", r.iterations},
            {"iteration_bound", r.iteration_bound},
            {"held_back", r.held_back},
            {"pairs", std::move(pairs)},
            {"held_by", r.held_by},
            {"suggestions", r.suggestions}};
  return j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}
}  // namespace

void RunRecorder::finish(const std::string& status) {
  if (const auto& stop = sim_.stop_report(); stop && status != "completed") {
    // The stopped frame's row (its frame is not on disk), unless no frame was simulated before:
    // a staged run that stops then is discarded whole.
    if (!writer_.staged()) writer_.write_stats(stop->stats);
    writer_.set_stop(stop_json(*stop));
  }
  writer_.finish(status);
}

}  // namespace ccfr::io
