// A registered material constraint's section in a material (`materials.<name>.<constraint>`):
// read with its defaults, switched on only for the materials that set it, checked like every
// other key (type, range, unknown keys: file, line and key path), and listed in the reference.
// A constraint whose parameters are keys of the material itself (as the built-ins' compliances)
// is read from those keys for every material.
// In the apps suite: the registration stays for the rest of the process, and the io suite
// compares docs/config.md with the built-in registry.
#include <gtest/gtest.h>

#include <string>

#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "config_support.hpp"

using namespace ccfr;

namespace {

// Accepts its section and builds nothing: these tests are about reading it.
const Registration<MaterialConstraintRegistry> spring(
    material_constraints(),
    {"test_spring",
     "test: a section with two keys",
     {ParamSpec::number("stiffness", 2.0, "N/m", 0.0, 1e9, true), ParamSpec::integer("rings", 3, "count", 1, 10)},
     [](const ParamValues&, const MaterialContext&) -> std::unique_ptr<ConstraintBatch> { return nullptr; }});

// Reads the material key `test_drag_coefficient`, as `stretch` reads `stretch_compliance`.
const Registration<MaterialConstraintRegistry> drag(
    material_constraints(),
    {"test_drag",
     "test: a parameter that is a key of the material",
     {ParamSpec::number("coefficient", 0.5, "kg/s", 0.0, 10.0).from_material("test_drag_coefficient")},
     [](const ParamValues&, const MaterialContext&) -> std::unique_ptr<ConstraintBatch> { return nullptr; }});

const char* kScene = R"(scene: t
time: {fps: 60, frames: 2}
materials:
  soft: {density: 0.2, test_spring: {stiffness: 5}}
  hard: {density: 0.3}
objects:
  - {name: a, kind: cloth, material: soft, shape: {type: grid, size: [1, 1], resolution: [2, 2]}}
  - {name: b, kind: cloth, material: hard, shape: {type: grid, size: [1, 1], resolution: [2, 2]},
     transform: {translate: [0, 1, 0]}}
)";

}  // namespace

TEST(MaterialSections, ASectionSwitchesItsConstraintOnWithDefaultsForTheRest) {
  const auto loaded = io::load_scene_text(kScene, "scene.yaml", ".");
  const auto& soft = loaded.scene.params.objects[0].material.constraints;
  ASSERT_EQ(soft.count("test_spring"), 1u);
  EXPECT_EQ(soft.at("test_spring").number("stiffness"), 5.0);
  EXPECT_EQ(soft.at("test_spring").integer("rings"), 3);
  EXPECT_EQ(loaded.scene.params.objects[1].material.constraints.count("test_spring"), 0u);
  // Set from the command line like any key.
  const auto set = io::load_scene_text(kScene, "scene.yaml", ".", {"materials.hard.test_spring.rings=7"});
  EXPECT_EQ(set.scene.params.objects[1].material.constraints.at("test_spring").integer("rings"), 7);
}

TEST(MaterialSections, BadValuesNameFileLineAndKey) {
  auto e = test::config_error(kScene, {"materials.soft.test_spring.stiffness=0"});
  EXPECT_EQ(e.key_path(), "materials.soft.test_spring.stiffness");
  e = test::config_error(std::string(kScene).replace(std::string(kScene).find("stiffness: 5"), 12, "stifness: 5"));
  EXPECT_EQ(e.key_path(), "materials.soft.test_spring.stifness");
  EXPECT_EQ(e.line(), 4);
  EXPECT_NE(std::string(e.what()).find("stiffness"), std::string::npos) << e.what();  // the suggestion
  e = test::config_error(std::string(kScene).replace(std::string(kScene).find("stiffness: 5"), 12, "rings: 1.5"));
  EXPECT_EQ(e.key_path(), "materials.soft.test_spring.rings");
}

TEST(MaterialSections, TheReferenceListsTheConstraintAndItsKeys) {
  const std::string md = io::config_reference_markdown();
  EXPECT_NE(md.find("| material constraint |"), std::string::npos);
  EXPECT_NE(md.find("`materials.<material>.test_spring.stiffness`"), std::string::npos);
  for (const char* builtin : {"`stretch`", "`dihedral_bending`", "`strand_bending`", "`tet_elasticity`"})
    EXPECT_NE(md.find(builtin), std::string::npos) << builtin;
}

TEST(MaterialSections, AConstraintReadingMaterialKeysGetsThemForEveryMaterial) {
  const auto loaded = io::load_scene_text(kScene, "scene.yaml", ".", {"materials.soft.test_drag_coefficient=2"});
  const auto& soft = loaded.scene.params.objects[0].material.constraints;
  const auto& hard = loaded.scene.params.objects[1].material.constraints;
  EXPECT_EQ(soft.at("test_drag").number("coefficient"), 2.0);
  EXPECT_EQ(hard.at("test_drag").number("coefficient"), 0.5);  // its default
  // The built-ins the same way: bend_compliance feeds both bending constraints.
  const auto bent = io::load_scene_text(kScene, "scene.yaml", ".", {"materials.hard.bend_compliance=0.25"});
  const auto& b = bent.scene.params.objects[1].material.constraints;
  EXPECT_EQ(b.at("dihedral_bending").number("compliance"), 0.25);
  EXPECT_EQ(b.at("strand_bending").number("compliance"), 0.25);
  EXPECT_EQ(b.at("stretch").number("compliance"), 0.0);
  EXPECT_EQ(b.at("tet_elasticity").number("shear_compliance"), 1e-6);
  // Checked as a key of the material, with its range; it has no section of its own.
  auto e = test::config_error(kScene, {"materials.soft.test_drag_coefficient=11"});
  EXPECT_EQ(e.key_path(), "materials.soft.test_drag_coefficient");
  EXPECT_NE(std::string(e.what()).find("10"), std::string::npos) << e.what();
  e = test::config_error(kScene, {"materials.soft.test_drag.coefficient=1"});
  EXPECT_EQ(e.key_path(), "materials.soft.test_drag");
  e = test::config_error(kScene, {"materials.soft.stretch_compliance=-1"});
  EXPECT_EQ(e.key_path(), "materials.soft.stretch_compliance");
  const std::string md = io::config_reference_markdown();
  EXPECT_NE(md.find("| `materials.<name>.test_drag_coefficient` | number | `0.5` |"), std::string::npos);
  EXPECT_NE(md.find("| `test_drag` | `materials.<material>.test_drag_coefficient` |"), std::string::npos);
}
