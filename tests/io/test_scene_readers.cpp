// The scene builder reads through the schema (issue #36): keys read into enums and flags go
// through one choice table each, defaults come from the parameter structs, and every shape type
// of the schema has a reader. The expected values here are written out independently.
#include <gtest/gtest.h>

#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "config_support.hpp"

using namespace ccfr;

namespace {

const char* kScene = R"(scene: t
time: {fps: 60, frames: 2}
objects:
  - name: sheet
    kind: cloth
    shape: {type: grid, size: [1, 1], resolution: [2, 2]}
  - name: hair
    kind: strand
    shape: {type: strands, count: 4, vertices: 3, length: 0.2, spread: 0.1}
    transform: {translate: [0, 2, 0]}
)";

/// Every choice of every table-read key, with the value it must load to (as an int, read back
/// from the loaded scene by `get`).
struct Expected {
  std::map<std::string, int> values;  ///< choice -> value, in no particular order
  std::vector<std::string> order;     ///< the schema's (documented) order
  std::function<int(const io::LoadedScene&)> get;
};

/// Roots of the strands lie on one row (equal z) or on a square grid (two z values).
int strands_in_a_row(const io::LoadedScene& s) {
  const auto& o = s.scene.topo.objects[1];
  std::set<double> z;
  for (Index l = o.polyline_begin; l < o.polyline_end; ++l)
    z.insert(s.scene.state.x[s.scene.topo.polylines.row(l)[0]].z());
  return z.size() == 1 ? 1 : 0;
}

std::map<std::string, Expected> expected() {
  using C = TimeParams::Continuation;
  return {
      {"time.continuation",
       {{{"full", int(C::full)}, {"held_back", int(C::held_back)}},
        {"full", "held_back"},
        [](const io::LoadedScene& s) { return int(s.scene.params.time.continuation); }}},
      {"contact.on_violation",
       {{{"auto", int(ViolationPolicy::automatic)},
         {"error", int(ViolationPolicy::error)},
         {"warn", int(ViolationPolicy::warn)}},
        {"auto", "error", "warn"},
        [](const io::LoadedScene& s) { return int(s.scene.params.contact.on_violation); }}},
      {"debug.audit",
       {{{"off", int(AuditMode::off)},
         {"every_frame", int(AuditMode::every_frame)},
         {"every_substep", int(AuditMode::every_substep)}},
        {"off", "every_frame", "every_substep"},
        [](const io::LoadedScene& s) { return int(s.scene.params.debug.audit); }}},
      {"objects.shape.layout", {{{"grid", 0}, {"row", 1}}, {"grid", "row"}, strands_in_a_row}},
  };
}

std::string override_for(const std::string& key, const std::string& choice) {
  if (key == "objects.shape.layout") return "objects.hair.shape.layout=" + choice;
  return key + "=" + choice;
}

}  // namespace

TEST(SceneReaders, EveryTableKeyOffersExactlyItsChoicesAndEachLoadsToItsValue) {
  const auto want = expected();
  const auto got = io::table_choices();
  ASSERT_EQ(got.size(), want.size()) << "a key read through a choice table is missing here, or one went";
  for (const auto& [key, choices] : got) {
    SCOPED_TRACE(key);
    ASSERT_TRUE(want.count(key)) << "no expectation for " << key;
    const Expected& e = want.at(key);
    EXPECT_EQ(choices, e.order);  // the schema offers every choice of the table, in its order
    std::set<int> seen;
    for (const auto& choice : choices) {
      SCOPED_TRACE(choice);
      ASSERT_TRUE(e.values.count(choice));
      const auto s = io::load_scene_text(kScene, "scene.yaml", ".", {override_for(key, choice)});
      EXPECT_EQ(e.get(s), e.values.at(choice));
      seen.insert(e.get(s));
    }
    // Every value (enumerator) is reached by exactly one choice.
    EXPECT_EQ(seen.size(), e.values.size());
  }
}

TEST(SceneReaders, SchemaAndReadersAgree) {
  const auto problems = io::reader_schema_mismatches();
  for (const auto& p : problems) ADD_FAILURE() << p;
  EXPECT_TRUE(problems.empty());
}

TEST(SceneReaders, UnsetKeysTakeTheParameterStructsDefaults) {
  const auto s = io::load_scene_text(kScene, "scene.yaml", ".");
  const auto& p = s.scene.params;
  const TimeParams t;
  EXPECT_EQ(p.time.substeps, t.substeps);
  EXPECT_EQ(p.time.iterations, t.iterations);
  EXPECT_EQ(p.time.max_iterations, t.max_iterations);
  EXPECT_EQ(p.time.xpbd_sweeps, t.xpbd_sweeps);
  EXPECT_EQ(p.time.max_subdivision, t.max_subdivision);
  EXPECT_EQ(p.time.gravity, t.gravity);
  EXPECT_EQ(p.time.damping, t.damping);
  EXPECT_EQ(p.time.advance_tolerance, t.advance_tolerance);
  EXPECT_EQ(p.time.advance_shortfall, t.advance_shortfall);
  EXPECT_EQ(p.time.continuation, t.continuation);
  const ContactParams c;
  EXPECT_EQ(p.contact.solver, c.solver);
  EXPECT_EQ(p.contact.radius, c.radius);
  EXPECT_EQ(p.contact.offset, c.offset);
  EXPECT_EQ(p.contact.repulsion_range, c.repulsion_range);
  EXPECT_EQ(p.contact.stiffness, c.stiffness);
  EXPECT_EQ(p.contact.friction_static, c.friction_static);
  EXPECT_EQ(p.contact.friction_kinetic, c.friction_kinetic);
  EXPECT_EQ(p.contact.epsilon, c.epsilon);
  EXPECT_EQ(p.contact.on_violation, c.on_violation);
  EXPECT_EQ(p.collision.broad_phase, DetectionParams{}.broad_phase);
  EXPECT_EQ(p.collision.reuse_skin, DetectionParams{}.reuse_skin);
  EXPECT_EQ(p.debug.audit, DebugParams{}.audit);
  EXPECT_EQ(p.debug.audit_tolerance, DebugParams{}.audit_tolerance);
  EXPECT_EQ(p.output.every, OutputParams{}.every);
  EXPECT_EQ(p.output.checkpoint_every, OutputParams{}.checkpoint_every);
  EXPECT_TRUE(p.output.formats.empty());  // absent: obj only
  const MaterialParams m;
  EXPECT_EQ(p.objects[0].material.density, m.density);
  // Every material key the constraints read is at its registered default.
  for (const auto& e : material_constraints().entries())
    for (const ParamSpec& spec : e.params)
      EXPECT_EQ(p.objects[0].material.constraints.at(e.name).values().at(spec.key), spec.default_value)
          << e.name << "." << spec.key;
  EXPECT_EQ(p.objects[0].material.friction, m.friction);
  // An absent motion is the struct's (holding for ever); a given one ends at the schema's 1e9 s.
  EXPECT_EQ(p.objects[0].motion.end, Motion{}.end);
  const auto moved = io::load_scene_text(kScene, "scene.yaml", ".",
                                         {"objects.sheet.kind=obstacle", "objects.sheet.motion.velocity=[0, 0, 1]"});
  EXPECT_EQ(moved.scene.params.objects[0].motion.end, 1e9);
  EXPECT_EQ(moved.scene.params.objects[0].motion.axis, Motion{}.axis);
}

TEST(SceneReaders, AChoiceOutsideTheTableNamesTheKeyAndTheChoices) {
  const auto e = test::config_error(kScene, {"debug.audit=sometimes"});
  EXPECT_EQ(e.key_path(), "debug.audit");
  for (const char* c : {"off", "every_frame", "every_substep"})
    EXPECT_NE(std::string(e.what()).find(c), std::string::npos) << e.what();
  const auto layout = test::config_error(std::string(kScene) + "    # end\n", {"objects.hair.shape.layout=column"});
  EXPECT_EQ(layout.key_path(), "objects[1].shape.layout");
}

TEST(SceneReaders, AnEmptyFormatListNamesEveryFormatOfTheSchema) {
  const auto e = test::config_error(std::string(kScene) + "output: {formats: []}\n");
  EXPECT_EQ(e.key_path(), "output.formats");
  EXPECT_EQ(e.line(), 11);
  EXPECT_NE(std::string(e.what()).find("list at least one format (obj, pc2, ply, usda, vtu)"), std::string::npos)
      << e.what();
}
