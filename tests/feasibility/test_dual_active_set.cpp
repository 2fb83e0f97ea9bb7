// The exact projection for many planes (dual active-set path of exact_region_projection, used
// above 24 planes) against the independent brute-force reference.
#include <gtest/gtest.h>

#include "ccfr/feasibility/exact_projector.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "random_regions.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

// A strand vertex squeezed between a comb tooth driven at 1.5 m/s and its neighbours (issue #39,
// item 6): 36 planes recorded from that run, a region with no feasible point. Planes 10 and 26 are
// nearly antiparallel (1.6e-5 rad apart), so reaching both needs y > 100 m, which plane 34 forbids.
// The dual active-set method took primal steps along the nearly null direction of that pair, grew
// x to infinity and, since every slack was then NaN, reported it as a feasible projection.
std::vector<HalfSpace> comb_squeeze_planes() {
  const double raw[][4] = {
      {0.97030086309813146, -0, 0.24190129199948754, -0.00031675442229139373},
      {0.97993495704888001, -0.015894621172487477, -0.19868276465610366, 4.0951785231836593e-05},
      {1, 1.0408340855860869e-13, -6.9388939039072465e-15, -5.2041704279304213e-18},
      {1, -0, 1.3877787807814493e-14, -2.6888213877640683e-17},
      {0.9277381092313588, -0.029763455433850075, -0.37204319292316135, 0.00015578079643296071},
      {0.29395840838899534, -0, -0.95581821186740756, 0.0048036835923856054},
      {0.9277381092313588, -0.029763455433850075, -0.37204319292316135, 0.00015578079643296071},
      {0.25761810364703241, -0, -0.96624681767823017, 0.0057634295559454429},
      {0.27479252793488318, -0.92471924461461563, -0.26340726115756768, 0.0052782182799161262},
      {-0.93698102060025046, 0.037479240824011759, 0.34736417999294161, -0.0011073439987529284},
      {0, 0, 1, -0.0030638891027014014},
      {-0.93698102060025046, 0.037479240824011759, 0.34736417999294161, -0.0011073439987529284},
      {-0.98685123408381559, 0.039474049363349667, 0.15673685340120183, -0.0008373571882117557},
      {-0.29395840838899723, -0, -0.95581821186740712, 0.0048036835923856089},
      {-0.97993495704888034, -0.015894621172487369, -0.19868276465610232, 4.0951785231850037e-05},
      {-0.97030086309813213, -0, 0.24190129199948432, -0.00031675442229136142},
      {-0.15877580473388825, 0.0063510321893549826, -0.98729423588980614, 0.0045867746908546236},
      {-0.92773810923136046, -0.029763455433849718, -0.37204319292315685, 0.00015578079643298673},
      {-0.27479252793487663, -0.9247192446146173, -0.26340726115756874, 0.0052782182799160976},
      {-0.25761810364703575, -0, -0.96624681767822929, 0.0057634295559454507},
      {-0.92773810923136035, -0.029763455433856147, -0.3720431929231568, 0.00015578079643298716},
      {-1, -5.5511151231257392e-14, -6.9388939039071739e-15, 1.5612511283791264e-17},
      {-1, -0, -1.3877787807814397e-14, 8.6736173798840355e-18},
      {-9.2501452849691625e-16, 0, -1, 0.0055013891027013862},
      {-0.17647548056764292, 0.0070590192227060452, -0.98427972396368757, 0.0056211964140573355},
      {-0.17647548056764292, 0.0070590192227060452, -0.98427972396368757, 0.0056211964140573355},
      {0, 1.6268152801213808e-05, -0.99999999986767363, 0.0012514856701385906},
      {0, 0.042810374958630965, -0.99908321565117952, 0.0012535501204408847},
      {-2.5112724105454159e-15, 0.09464875157956236, -0.99551073014027847, 0.0017630988477272324},
      {-2.5775652843006356e-15, -0.13211121770903619, -0.99123489958507605, 0.0016920342022646155},
      {-2.5225970331445835e-15, -1.5790085134699062e-08, -0.99999999999999989, 0.0017506945472212181},
      {2.0140122686543608e-15, -0.2442229696346942, -0.96971910422699792, 0.0024453086567061333},
      {0, 0.92776101129221855, 0.37317489991428926, 0.0026170695700590604},
      {-9.1826271355567552e-16, 0.99123489958507593, -0.13211121770903694, 0.0027782727107793612},
      {-2.9746476869161198e-15, -0.96174293860027071, -0.27395349979972139, 0.0049980326756957159},
      {-0.27479252793487663, -0.9247192446146173, -0.26340726115756874, 0.0052782182799160976},
  };
  std::vector<HalfSpace> planes;
  for (const auto& r : raw) planes.push_back(HalfSpace{Vec3(r[0], r[1], r[2]), r[3]});
  return planes;
}

TEST(ExactManyPlanes, NearlyParallelPairOfAnEmptyRegionGivesNoNonFinitePoint) {
  const auto planes = comb_squeeze_planes();
  ASSERT_EQ(planes.size(), 36u);  // above the enumeration limit: the dual active-set path
  // The candidate of the recorded vertex, relative to its anchor.
  const Vec3 q = Vec3(-0.056070990723754155, 0.074347571589608988, -0.090924560505989599) -
                 Vec3(-0.056736842105263141, 0.07367765566376569, -0.089438889102701397);
  // Independent reference (every active set of at most three planes): no feasible point.
  Vec3 ref;
  ASSERT_FALSE(ccfr::test::reference_projection(q, planes, 1e-12, ref));
  for (const double margin : {0.0, 2e-7}) {
    const ExactProjection e = exact_region_projection(q, planes, margin, 1e-12);
    EXPECT_FALSE(e.found) << "margin " << margin << ": p = " << e.p.transpose();
  }
  // The projectors then keep the vertex at its (finite) anchor and say so.
  ProjectorParams pp;
  pp.epsilon = 2e-7;  // ε ξ of the run (ξ = 2 mm)
  const Vec3 anchor(-0.056736842105263141, 0.07367765566376569, -0.089438889102701397);
  for (const char* name : {"exact", "plesnik", "successive_projection"}) {
    const ProjectResult r = make_projector(name, pp)->project(anchor, anchor + q, planes);
    EXPECT_TRUE(r.x.allFinite()) << name;
    if (std::string(name) != "successive_projection") {
      EXPECT_EQ(r.status, ProjectStatus::infeasible) << name;
      EXPECT_EQ(r.x, anchor) << name;
    }
  }
}

}  // namespace

TEST(ExactManyPlanes, MatchesTheBruteForceReference) {
  auto g = ccfr::test::rng(2026);
  double worst = 0.0;
  int compared = 0;
  for (int trial = 0; trial < 120; ++trial) {
    const int m = 25 + trial % 16;  // above the enumeration limit
    const auto pr = ccfr::test::random_problem(g, m);
    const Vec3 q = pr.candidate - pr.anchor;
    Vec3 ref;
    if (!ccfr::test::reference_projection(q, pr.planes, 1e-12, ref)) continue;
    const ExactProjection e = exact_region_projection(q, pr.planes, 0.0, 1e-13);
    ASSERT_TRUE(e.found) << "trial " << trial;
    worst = std::max(worst, (e.p - ref).norm());
    ++compared;
    for (const auto& h : pr.planes) EXPECT_GE(h.n.dot(e.p) + h.d, -1e-12);
  }
  EXPECT_GT(compared, 100);
  EXPECT_LT(worst, 1e-10);
}

TEST(ExactManyPlanes, HundredsOfPlanesWithAnInfeasibleAnchor) {
  // d < 0 for some planes (clarification 7): still the projection onto the region, which here
  // is a small box around a point at distance 0.003 from the anchor.
  auto g = ccfr::test::rng(11);
  std::vector<HalfSpace> planes;
  const Vec3 c(0.003, 0.0, 0.0);
  for (int k = 0; k < 300; ++k) {
    HalfSpace h;
    h.n = ccfr::test::random_unit(g);
    h.d = 0.001 - h.n.dot(c);  // n.(p - c) + 0.001 >= 0: every plane passes 1 mm from c
    planes.push_back(h);
  }
  const Vec3 q(0.05, 0.02, -0.01);
  const ExactProjection e = exact_region_projection(q, planes, 0.0, 1e-13);
  ASSERT_TRUE(e.found);
  for (const auto& h : planes) EXPECT_GE(h.n.dot(e.p) + h.d, -1e-12);
  // Optimality: no sampled feasible point is closer to q (the region is within 1 mm of c).
  std::uniform_real_distribution<double> u(-0.0012, 0.0012);
  for (int s = 0; s < 20000; ++s) {
    const Vec3 y = c + Vec3(u(g), u(g), u(g));
    bool ok = true;
    for (const auto& h : planes) ok = ok && h.n.dot(y) + h.d >= 0.0;
    if (ok) EXPECT_GE((y - q).norm(), (e.p - q).norm() - 1e-12);
  }
}

TEST(ExactManyPlanes, EmptyRegionIsReported) {
  std::vector<HalfSpace> planes;
  for (int k = 0; k < 30; ++k) {
    HalfSpace a, b;
    a.n = Vec3::UnitX();
    a.d = -0.01;  // x >= 0.01
    b.n = -Vec3::UnitX();
    b.d = 0.0;  // x <= 0
    planes.push_back(a);
    planes.push_back(b);
  }
  EXPECT_FALSE(exact_region_projection(Vec3(0.5, 0, 0), planes, 0.0, 1e-13).found);
}

// A sheet vertex squeezed between two closing plates (configs/stress/squeeze_one.yaml, frame 23,
// margin ε ξ): 28 planes on which the dual active-set method proves nothing, so Hildreth's sweeps
// run. The region is empty; Hildreth's worst violation then repeats every sweep, and it stops at
// its second block (the stress run took 25 s of its 26 in 20000-sweep calls like this one).
TEST(ExactManyPlanes, SqueezedSheetVertexFallsThroughToHildrethAndIsEmpty) {
  const double raw[][4] = {
      {-0x1.6a0720b342dcp-1, -0x1.02f5be4c3b003p-11, 0x1.6a0ca64d6aab8p-1, 0x1.8f6acbe2a113bp-9},
      {0x1.6a0d5898b397ep-1, -0x1.97adb19d9ab12p-10, 0x1.6a063acbf1659p-1, 0x1.8f6db526b1821p-9},
      {-0x1.6a06e8b16a2cap-1, 0x1.54dcdfbeecf53p-9, 0x1.6a0c43a2e2f59p-1, 0x1.8f6c8102d3c6ep-8},
      {0x1.6a0d8045a8482p-1, 0x1.19119eed553efp-9, 0x1.6a05df6551ef5p-1, 0x1.8f6d8542f8695p-8},
      {-0x1.6a06e8b16a2cap-1, 0x1.54dcdfbeecf53p-9, 0x1.6a0c43a2e2f59p-1, 0x1.8f6c8102d3c6dp-8},
      {-0x1.6a06e8b16a2cap-1, 0x1.54dcdfbeecf53p-9, 0x1.6a0c43a2e2f59p-1, 0x1.8f6c8102d3c6ep-8},
      {0x1.6a068ebe05ddfp-1, 0x1.663bce8af65b4p-10, -0x1.6a0d11bb62e9bp-1, 0x1.8f6d0f478676ep-8},
      {0x1.24c9bb61d7219p-1, -0x1.2d27b07841bd7p-1, -0x1.24c9bb61d720bp-1, 0x1.d2c8308f4ec1ep-9},
      {0x1.244c2a9d3d08p-1, 0x1.2e1b40fecc75bp-1, -0x1.244c2a9d3d071p-1, 0x1.eccc3ed8bc9f6p-9},
      {0x1.6a0d8045a8482p-1, 0x1.19119eed553efp-9, 0x1.6a05df6551ef5p-1, 0x1.8f6d8542f8695p-8},
      {-0x1.6a0d5725f4612p-1, 0x1.ddd17428f225p-10, -0x1.6a0626ccd5acbp-1, 0x1.8f6d23d31373ep-8},
      {-0x1.6a0d5725f4612p-1, 0x1.ddd17428f225p-10, -0x1.6a0626ccd5acbp-1, 0x1.8f6d23d31373ep-8},
      {-0x1.6a0d5725f4612p-1, 0x1.ddd17428f225p-10, -0x1.6a0626ccd5acbp-1, 0x1.8f6d23d31373ep-8},
      {0x1.6a068ebe05ddfp-1, 0x1.663bce8af65b4p-10, -0x1.6a0d11bb62e9bp-1, 0x1.8f6d0f478676dp-8},
      {0x1.6a068ebe05ddfp-1, 0x1.663bce8af65b4p-10, -0x1.6a0d11bb62e9bp-1, 0x1.8f6d0f478676dp-8},
      {0x1.6a0d8045a8482p-1, 0x1.19119eed553efp-9, 0x1.6a05df6551ef5p-1, 0x1.8f6d8542f8695p-8},
      {0x1.24c9bb61d7219p-1, -0x1.2d27b07841bd7p-1, -0x1.24c9bb61d720bp-1, 0x1.d2c8308f4ec1ep-9},
      {0x1.03151c931e1dbp-10, -0x1.ffffdf3987c19p-1, -0x1.03151c932125dp-10, -0x1.4d14386265f54p-13},
      {0x1.24c9bb61d7219p-1, -0x1.2d27b07841bd7p-1, -0x1.24c9bb61d720bp-1, 0x1.d2c8308f4ec1ep-9},
      {0x1.244c2a9d3d08p-1, 0x1.2e1b40fecc75bp-1, -0x1.244c2a9d3d071p-1, 0x1.eccc3ed8bc9f6p-9},
      {-0x1.03151c931e1f9p-10, 0x1.ffffdf3987c18p-1, 0x1.03151c931fa34p-10, 0x1.4d0ef9e8c33ep-13},
      {0x1.244c2a9d3d08p-1, 0x1.2e1b40fecc75bp-1, -0x1.244c2a9d3d071p-1, 0x1.eccc3ed8bc9f6p-9},
      {-0x1.82f1b353fdb9fp-50, 0x1p+0, 0x1.82f1b353fdb9fp-49, 0x1.61cca26f35e4p-13},
      {0x1.84d165c7c0763p-49, -0x1p+0, 0x0p+0, -0x1.61cca26f3504p-13},
      {0x1.6a06a3830be9ap-1, -0x1.f906f76aa48bdp-12, -0x1.6a0d23c46840ep-1, 0x1.8f6d7da656d71p-9},
      {-0x1.6a0d83dc06ccfp-1, -0x1.c7f958b6f201ap-10, -0x1.6a060120de055p-1, 0x1.8f6cf1ed6e331p-9},
      {0x1.ef12656b5b4a8p-11, -0x1.ffffe214bdf4p-1, -0x1.ef12656b615afp-11, -0x1.4e0083aea553p-13},
      {-0x1.ef12656b5f875p-11, 0x1.ffffe214bdf4p-1, 0x1.ef12656b5f875p-11, 0x1.4dfbba337116p-13},
  };
  std::vector<HalfSpace> planes;
  for (const auto& r : raw) planes.push_back(HalfSpace{Vec3(r[0], r[1], r[2]), r[3]});
  ASSERT_EQ(planes.size(), 28u);
  const Vec3 q(-0x1.d3b4aa2dbp-21, -0x1.4c8ffc454146p-13, -0x1.0425adc0cp-20);
  const double margin = 0x1.0c6f7a0b5ed8ep-21, tol = 0x1.19799812dea11p-40;
  // Independent reference (every active set of at most three planes, margin folded into d).
  std::vector<HalfSpace> shifted = planes;
  for (auto& h : shifted) h.d -= margin;
  Vec3 ref;
  ASSERT_FALSE(ccfr::test::reference_projection(q, shifted, 1e-12, ref));
  EXPECT_FALSE(exact_region_projection(q, planes, margin, tol).found);
  EXPECT_FALSE(exact_region_projection(q, planes, 0.0, tol).found);
}
