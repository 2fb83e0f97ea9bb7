// A stop says why (issue 37 item 7): a sheet squeezed between a fixed anvil and a scripted press
// stops the run; the error, run.json's `stop` and stats.csv name the pairs (object and local
// vertex), the cause, what holds the sheet (both obstacles, the press scripted) and what to change.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "cli_support.hpp"

namespace fs = std::filesystem;
using Json = nlohmann::json;
using ccfr::test::csv_column;
using ccfr::test::read_text;
using ccfr::test::run_ccfr;
using ccfr::test::scratch_dir;

namespace {

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

const std::string kSqueeze = std::string(CCFR_SOURCE_DIR) + "/tests/data/squeeze.yaml";

}  // namespace

TEST(StopReport, ASqueezeNamesPairsCauseHoldersAndRemedies) {
  for (const std::string solver : {"ccfr", "exact_projection"}) {
    SCOPED_TRACE(solver);
    const fs::path d = scratch_dir("stop_report_" + solver);
    const auto r = run_ccfr("run " + kSqueeze + " --out " + (d / "out").string() + " --solver " + solver);
    ASSERT_EQ(r.code, 1) << r.out;
    // The message: pairs by object name and index within the object, what holds them, what to change.
    EXPECT_TRUE(has(r.out, "violation(s) remain at the end of substep")) << r.out;
    EXPECT_TRUE(has(r.out, "'sheet' vertex")) << r.out;
    EXPECT_TRUE(has(r.out, "Cause: ")) << r.out;
    EXPECT_TRUE(has(r.out, "Held by: ")) << r.out;
    // Stopped after the substep was halved: the press's step is that of one of 2 pieces.
    EXPECT_TRUE(has(r.out, "the substep was solved again in 2 pieces")) << r.out;
    EXPECT_TRUE(has(r.out, "'press' (obstacle, scripted, 0.00125 m per substep piece)")) << r.out;
    EXPECT_TRUE(has(r.out, "What to change: slow the scripted motion of 'press'")) << r.out;
    EXPECT_TRUE(has(r.out, "raise time.substeps (now 4)")) << r.out;
    EXPECT_TRUE(has(r.out, "give the squeezed objects room")) << r.out;

    const Json j = Json::parse(read_text(d / "out" / "run.json"));
    ASSERT_TRUE(j.contains("stop")) << j.dump(2);
    const Json& s = j["stop"];
    EXPECT_EQ(s["reason"], "violations remain");
    EXPECT_EQ(s["solver"], solver);
    const int frames_written = j["frames_written"];
    EXPECT_EQ(s["frame"].get<int>(), frames_written);  // frame 0 is written too: frames 0..N-1 on disk
    EXPECT_TRUE(has(j["status"].get<std::string>(), "frame " + std::to_string(s["frame"].get<int>()) + ":"));
    EXPECT_GE(s["substep"].get<int>(), 1);
    EXPECT_LE(s["substep"].get<int>(), 4);
    EXPECT_GT(s["remaining"].get<int>(), 0);
    const std::set<std::string> causes = {"fixed_pair", "region_empty", "iterations_ran_out", "halted", "unresolved"};
    EXPECT_TRUE(causes.count(s["cause"].get<std::string>())) << s["cause"];
    EXPECT_LE(s["outer_iterations"].get<int>(), s["iteration_bound"].get<int>());
    // The pairs: a sheet vertex (local index in 0..24 of the 5 x 5 grid) against a box (0..7).
    ASSERT_FALSE(s["pairs"].empty());
    for (const Json& p : s["pairs"]) {
      EXPECT_LT(p["distance"].get<double>(), p["offset"].get<double>());
      EXPECT_DOUBLE_EQ(p["offset"].get<double>(), 0.01);
      std::set<std::string> objects;
      for (const char* side : {"a", "b"})
        for (const Json& v : p[side]) {
          const std::string o = v["object"];
          objects.insert(o);
          const int local = v["vertex"];
          EXPECT_GE(local, 0);
          if (o == "sheet") {
            EXPECT_LT(local, 25);
            EXPECT_FALSE(v["fixed"].get<bool>());
            EXPECT_TRUE(v["region_empty"].is_boolean());  // a movable vertex with a region: certified
          } else {
            EXPECT_TRUE(o == "press" || o == "anvil") << o;
            EXPECT_LT(local, 8);
            EXPECT_TRUE(v["fixed"].get<bool>());
            EXPECT_TRUE(v["region_empty"].is_null());
            EXPECT_EQ(v.contains("scripted_step"), o == "press");
          }
        }
      EXPECT_TRUE(objects.count("sheet")) << p.dump();
    }
    // The press holds the sheet (its close pairs are with the press; the anvil is at its offset).
    std::string held;
    for (const Json& h : s["held_by"]) held += h.get<std::string>() + ";";
    EXPECT_TRUE(has(held, "'press' (obstacle, scripted")) << held;
    EXPECT_GE(s["suggestions"].size(), 3u);
    // stats.csv: one row per frame written after frame 0, then the stopped frame's row.
    const auto frames = csv_column(d / "out" / "stats.csv", "frame");
    const auto remaining = csv_column(d / "out" / "stats.csv", "violations_remaining");
    ASSERT_EQ(static_cast<int>(frames.size()), frames_written);
    EXPECT_EQ(frames.back(), std::to_string(s["frame"].get<int>()));
    EXPECT_GT(std::stoi(remaining.back()), 0);
    for (size_t i = 0; i + 1 < remaining.size(); ++i) EXPECT_EQ(remaining[i], "0");
  }
}
