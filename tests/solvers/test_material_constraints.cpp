// Material constraints as registered components (material_constraint.hpp): one file per built-in
// under solvers/src/materials/ named by its key; a constraint registered here (as a downstream
// program would) is built only for the objects whose material sets it, solved in the place its
// sweep rank gives, and refused with a clear error when a material names it wrongly.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/solvers/material_system.hpp"
#include "ccfr/solvers/materials/stretch.hpp"
#include "ccfr/solvers/params.hpp"
#include "ccfr/solvers/scene.hpp"
#include "component_files.hpp"

using namespace ccfr;

namespace {

/// Keeps each vertex within `length` of its rest position: C = max(0, |x - x̄| - L), hard.
struct Leash final : ConstraintBatch {
  std::vector<Index> ids;
  std::vector<Vec3> anchor;
  std::vector<double> length;
  int rank = 100;
  Index size() const override { return static_cast<Index>(ids.size()); }
  int arity() const override { return 1; }
  std::span<const Index> vertex_ids() const override { return ids; }
  void reset_multipliers() override {}
  int sweep_rank() const override { return rank; }
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w, double) override {
    for (const Index c : order) {
      const Vec3 d = x[ids[c]] - anchor[c];
      if (w[ids[c]] > 0.0 && d.norm() > length[c]) x[ids[c]] = anchor[c] + length[c] * d.normalized();
    }
  }
};

MaterialConstraintRegistry::Factory leash_factory(int rank) {
  return [rank](const ParamValues&, const MaterialContext& ctx) -> std::unique_ptr<ConstraintBatch> {
    auto b = std::make_unique<Leash>();
    b->rank = rank;
    for (size_t o = 0; o < ctx.topo.objects.size(); ++o) {
      if (!ctx.object_params[o]) continue;
      for (Index v = ctx.topo.objects[o].vertex_begin; v < ctx.topo.objects[o].vertex_end; ++v) {
        b->ids.push_back(v);
        b->anchor.push_back(ctx.state.rest[v]);
        b->length.push_back(ctx.object_params[o]->number("length"));
      }
    }
    if (b->ids.empty()) return nullptr;
    return b;
  };
}

// Registered at static initialisation, after the built-ins (the accessor adds those first).
const Registration<MaterialConstraintRegistry> leash(
    material_constraints(), {"test_leash",
                             "test: each vertex within `length` of its rest position",
                             {ParamSpec::number("length", 0.25, "largest distance from rest (m)", 0.0)},
                             leash_factory(100)});
// The same kernel ranked before every built-in.
const Registration<MaterialConstraintRegistry> early(
    material_constraints(), {"test_early_leash",
                             "test: test_leash, ranked first in the sweep",
                             {ParamSpec::number("length", 0.25, "largest distance from rest (m)", 0.0)},
                             leash_factory(1)});

/// A cloth (index 0) and three particles (index 1) whose material is `m`; the third particle is
/// kinematic.
Scene cloth_and_particles(const MaterialParams& particle_material) {
  const auto cloth = gen::grid(1.0, 1.0, 3, 3);
  TopologyBuilder tb;
  tb.add_object("sheet", ObjectKind::cloth, static_cast<Index>(cloth.v.size()), cloth.f);
  tb.add_object("beads", ObjectKind::particles, 3);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  for (size_t i = 0; i < cloth.v.size(); ++i) s.state.x[i] = cloth.v[i];
  const Index p = static_cast<Index>(cloth.v.size());
  for (Index k = 0; k < 3; ++k) s.state.x[p + k] = Vec3(3.0 + k, 1.0, 0.0);
  for (Index v = 0; v < s.topo.num_vertices(); ++v) s.state.mass[v] = 1.0, s.state.inv_mass[v] = 1.0;
  s.state.inv_mass[p + 2] = 0.0;
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  s.params.objects[1].material = particle_material;
  return s;
}

MaterialParams with(const std::string& name, ParamValues values) {
  MaterialParams m;
  m.constraints[name] = std::move(values);
  return m;
}

}  // namespace

TEST(MaterialConstraintFiles, EveryFileUnderMaterialsIsTheRegisteredConstraintOfItsName) {
  const auto files = test::component_files("solvers/src/materials");
  ASSERT_EQ(files.size(), 4u);
  for (const auto& f : files) {
    EXPECT_NE(f.text.find("void register_material_constraint_" + f.key + "("), std::string::npos) << f.path;
    EXPECT_NE(f.text.find("\"" + f.key + "\""), std::string::npos) << f.path;
  }
  // The built-ins first, in the order of their files; this test's two entries after them.
  const auto names = material_constraints().names();
  ASSERT_GE(names.size(), files.size() + 2);
  EXPECT_EQ(std::vector<std::string>(names.begin(), names.begin() + static_cast<long>(files.size())),
            test::keys_of(files));
}

TEST(MaterialConstraints, RegisteredConstraintProjectsOntoItsSphereForItsObjectsOnly) {
  Scene s = cloth_and_particles(with("test_leash", {{"length", 0.1}}));
  const MaterialSystem ms(s.topo, s.state, s.params);
  const auto* b = ms.batch("test_leash");
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(b->size(), 3);                           // the beads only, not the cloth
  EXPECT_EQ(ms.batch("test_early_leash"), nullptr);  // no material sets it: no batch
  const Index p = s.topo.objects[1].vertex_begin;
  Positions x = s.state.rest;
  const Vec3 dir = Vec3(1, 2, 2) / 3.0;
  x[p] += 0.3 * dir;             // outside: projected onto the sphere of radius 0.1
  x[p + 1] += Vec3(0.05, 0, 0);  // inside: untouched
  x[p + 2] += Vec3(0, 0.5, 0);   // kinematic: untouched
  const Positions before = x;
  MaterialSystem solver(s.topo, s.state, s.params);
  solver.solve(x, s.state.inv_mass, 1e-3);
  EXPECT_LT((x[p] - (s.state.rest[p] + 0.1 * dir)).norm(), 1e-15);
  EXPECT_EQ(x[p + 1], before[p + 1]);
  EXPECT_EQ(x[p + 2], before[p + 2]);
}

TEST(MaterialConstraints, MissingParametersTakeTheirDefaults) {
  Scene s = cloth_and_particles(with("test_leash", {}));
  MaterialSystem ms(s.topo, s.state, s.params);
  const Index p = s.topo.objects[1].vertex_begin;
  Positions x = s.state.rest;
  x[p] += Vec3(0, -1, 0);
  ms.solve(x, s.state.inv_mass, 1e-3);
  EXPECT_NEAR(x[p].y(), s.state.rest[p].y() - 0.25, 1e-15);  // the declared default length
}

TEST(MaterialConstraints, SweepOrderFollowsTheRank) {
  MaterialParams m = with("test_leash", {{"length", 0.1}});
  m.constraints["test_early_leash"] = {{"length", 0.2}};
  Scene s = cloth_and_particles(m);
  const MaterialSystem ms(s.topo, s.state, s.params);
  std::vector<std::string> order;
  for (const auto& [name, n] : ms.counts().by_name) order.push_back(name);
  EXPECT_EQ(order, (std::vector<std::string>{"test_early_leash", "stretch", "dihedral_bending", "strand_bending",
                                             "tet_elasticity", "test_leash"}));
  // The last word is test_leash's (rank 100): a bead 1 m out ends 0.1 m from rest, not 0.2 m.
  MaterialSystem solve(s.topo, s.state, s.params);
  Positions x = s.state.rest;
  const Index p = s.topo.objects[1].vertex_begin;
  x[p] += Vec3(1, 0, 0);
  solve.solve(x, s.state.inv_mass, 1e-3);
  EXPECT_NEAR((x[p] - s.state.rest[p]).norm(), 0.1, 1e-15);
  // Both schedules agree bit for bit with a registered constraint in the sweep.
  MaterialSystem a(s.topo, s.state, s.params), c(s.topo, s.state, s.params);
  Positions xa = s.state.rest, xc = s.state.rest;
  for (Index v = 0; v < s.topo.num_vertices(); ++v) xa[v] += Vec3(0.01 * v, -0.3, 0.02), xc[v] = xa[v];
  for (int k = 0; k < 3; ++k) a.solve(xa, s.state.inv_mass, 1e-3), c.solve_by_colour(xc, s.state.inv_mass, 1e-3);
  EXPECT_EQ(xa, xc);
}

TEST(MaterialConstraints, WrongNamesAndValuesAreClearErrors) {
  auto message = [](const MaterialParams& m) {
    Scene s = cloth_and_particles(m);
    try {
      MaterialSystem ms(s.topo, s.state, s.params);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string e = message(with("test_lesh", {}));
  EXPECT_NE(e.find("object 'beads'"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown material constraint 'test_lesh'"), std::string::npos) << e;
  EXPECT_NE(e.find("test_leash"), std::string::npos) << e;  // lists the ones a material can set
  e = message(with("stretch", {{"compliance", -1.0}}));     // a built-in's value, set in code
  EXPECT_NE(e.find("material constraint 'stretch' of object 'beads'"), std::string::npos) << e;
  EXPECT_NE(e.find("'compliance'"), std::string::npos) << e;
  e = message(with("test_leash", {{"length", -1.0}}));
  EXPECT_NE(e.find("'length'"), std::string::npos) << e;
  EXPECT_NE(e.find("beads"), std::string::npos) << e;
  e = message(with("test_leash", {{"lenght", 1.0}}));
  EXPECT_NE(e.find("lenght"), std::string::npos) << e;
}

TEST(MaterialConstraints, TheBuiltInsReadTheMaterialKeysThroughTheirRegisteredParameters) {
  // Each key once, in registration order; bend_compliance serves both bending constraints.
  std::vector<std::string> keys;
  for (const ParamSpec& k : material_keys()) keys.push_back(k.key);
  EXPECT_EQ(keys, (std::vector<std::string>{"bend_compliance", "stretch_compliance", "volume_compliance",
                                            "shear_compliance"}));
  MaterialParams m;
  set_material_key(m, "bend_compliance", 0.5);
  set_material_key(m, "stretch_compliance", 1e-5);
  EXPECT_EQ(m.constraints.at("dihedral_bending").number("compliance"), 0.5);
  EXPECT_EQ(m.constraints.at("strand_bending").number("compliance"), 0.5);
  // The cloth's stretch batch holds the compliance set for its material, per edge.
  Scene s = cloth_and_particles(MaterialParams{});
  s.params.objects[0].material = m;
  const MaterialSystem ms(s.topo, s.state, s.params);
  const auto* stretch = dynamic_cast<const DistanceBatch*>(ms.batch("stretch"));
  ASSERT_NE(stretch, nullptr);
  ASSERT_GT(stretch->size(), 0);
  for (const double alpha : stretch->compliance) EXPECT_EQ(alpha, 1e-5);
  try {
    set_material_key(m, "stretch_complience", 1.0);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'stretch_complience'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("stretch_compliance"), std::string::npos) << e.what();  // the keys read
  }
}

TEST(MaterialConstraints, AnEntryMixingMaterialKeysAndASectionIsRefused) {
  MaterialConstraintRegistry::Entry e{
      "mixed",
      "test",
      {ParamSpec::number("a", 1.0, "doc").from_material("mixed_a"), ParamSpec::number("b", 1.0, "doc")},
      [](const ParamValues&, const MaterialContext&) -> std::unique_ptr<ConstraintBatch> { return nullptr; }};
  EXPECT_THROW(on_for_every_material(e), Error);
  e.params.pop_back();
  EXPECT_TRUE(on_for_every_material(e));
  e.params.front().material_key.clear();
  EXPECT_FALSE(on_for_every_material(e));
  e.params.clear();
  EXPECT_TRUE(on_for_every_material(e));  // no parameters: always on
  // Two constraints may share a material key only with one type, default and range.
  MaterialConstraintRegistry r("material constraint");
  auto entry = [&](std::string name, double def) {
    return MaterialConstraintRegistry::Entry{
        std::move(name), "test", {ParamSpec::number("k", def, "doc", 0.0, 1.0).from_material("shared_k")}, e.make};
  };
  r.add(entry("first", 0.5));
  r.add(entry("second", 0.5));
  ASSERT_EQ(material_keys(r).size(), 1u);
  EXPECT_EQ(material_keys(r).front().key, "shared_k");
  r.add(entry("third", 0.25));
  EXPECT_THROW(material_keys(r), Error);
}
