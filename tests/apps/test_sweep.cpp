// `ccfr sweep` with the local backend and `ccfr ablate` (its solvers-only case): strict specs, the
// cells a spec expands to, each cell equal to the same `ccfr run` done by hand, status / resume /
// collect. The Slurm backend is tested on a real cluster by tests/cluster/slurm_sweep.sh.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/sweep_spec.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using ccfr::test::read_text;
using ccfr::test::run_ccfr;

namespace {

void write(const fs::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << s;
}

std::string cfg(const std::string& name) { return std::string(CCFR_SOURCE_DIR) + "/configs/" + name; }

// Expects the spec to be refused with a message holding every one of `parts`.
void expect_refused(const fs::path& spec, const std::string& text, std::initializer_list<std::string> parts) {
  write(spec, text);
  try {
    ccfr::io::load_sweep_spec(spec);
    ADD_FAILURE() << "accepted:\n" << text;
  } catch (const ccfr::Error& e) {
    for (const auto& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what() << "\nwanted: " << p;
  }
}

}  // namespace

TEST(SweepSpec, ProductZipAndCasesExpandToStableCells) {
  const fs::path d = ccfr::test::scratch_dir("sweep_spec");
  const fs::path spec = d / "s.yaml";
  write(spec, "configs: [" + cfg("drape.yaml") + ", " + cfg("two_sheets.yaml") +
                  "]\nsolvers: [ccfr, exact_projection, post_process]\nparameters:\n  contact.offset: [0.008, 0.01]\n"
                  "  time.substeps: [2, 4]\nframes: 3\nset: {output.every: 2}\n");
  const auto s = ccfr::io::load_sweep_spec(spec);
  ASSERT_EQ(s.cells.size(), 2u * 3u * 2u * 2u);  // brute force: configs x solvers x offsets x substeps
  EXPECT_EQ(s.cells[0].id, "drape__ccfr__contact.offset=0.008__time.substeps=2");
  EXPECT_EQ(s.cells[1].id, "drape__ccfr__contact.offset=0.008__time.substeps=4");
  EXPECT_EQ(s.cells.back().id, "two_sheets__post_process__contact.offset=0.01__time.substeps=4");
  EXPECT_EQ(s.cells[0].overrides, (std::vector<std::string>{"output.every=2", "time.frames=3", "contact.solver=ccfr",
                                                            "contact.offset=0.008", "time.substeps=2"}));
  // The same spec gives the same ids.
  const auto again = ccfr::io::load_sweep_spec(spec);
  for (size_t i = 0; i < s.cells.size(); ++i) EXPECT_EQ(s.cells[i].id, again.cells[i].id);

  write(spec, "configs: [" + cfg("drape.yaml") +
                  "]\nparameters:\n  contact.offset: [0.008, 0.01, 0.012]\n  contact.radius: [0.004, 0.005, 0.006]\n"
                  "combine: zip\n");
  const auto z = ccfr::io::load_sweep_spec(spec);
  ASSERT_EQ(z.cells.size(), 3u);
  EXPECT_EQ(z.cells[2].id, "drape__scene__contact.offset=0.012__contact.radius=0.006");

  write(spec, "configs: [" + cfg("drape.yaml") + "]\ncases:\n  - {contact.offset: 0.01}\n  - {contact.offset: 0.02}\n");
  EXPECT_EQ(ccfr::io::load_sweep_spec(spec).cells.size(), 2u);
  // Degenerate: one config, nothing swept: one cell.
  write(spec, "configs: [" + cfg("drape.yaml") + "]\n");
  EXPECT_EQ(ccfr::io::load_sweep_spec(spec).cells.size(), 1u);
}

// parameters: {} and cases: [{}] sweep nothing: one cell per config and solver, as with neither,
// whichever `combine`.
TEST(SweepSpec, EmptyParametersAreOneCaseInEitherCombine) {
  const fs::path d = ccfr::test::scratch_dir("sweep_spec_empty");
  const fs::path spec = d / "s.yaml";
  const std::string c = "configs: [" + cfg("drape.yaml") + "]\nsolvers: [ccfr, post_process]\n";
  for (const std::string& rest :
       {std::string(), std::string("parameters: {}\n"), std::string("parameters: {}\ncombine: product\n"),
        std::string("parameters: {}\ncombine: zip\n"), std::string("cases: [{}]\n")}) {
    SCOPED_TRACE(rest);
    write(spec, c + rest);
    const auto s = ccfr::io::load_sweep_spec(spec);
    ASSERT_EQ(s.cells.size(), 2u);
    EXPECT_EQ(s.cells[0].id, "drape__ccfr");
    EXPECT_EQ(s.cells[1].id, "drape__post_process");
    EXPECT_TRUE(s.parameter_keys.empty());
    for (const auto& cell : s.cells) EXPECT_TRUE(cell.params.empty());
  }
}

TEST(SweepSpec, ThePaperSweepCoversEveryConfigAndSolver) {
  const auto s = ccfr::io::load_sweep_spec(cfg("sweeps/paper.yaml"));
  size_t scenes = 0;
  for (const auto& e : fs::directory_iterator(fs::path(CCFR_SOURCE_DIR) / "configs"))
    scenes += e.path().extension() == ".yaml";
  EXPECT_EQ(s.configs.size(), scenes);
  EXPECT_EQ(s.solvers, ccfr::registered_contact_solvers());  // every registered solver
  EXPECT_EQ(s.cells.size(), scenes * s.solvers.size());
}

// The comparison of contact methods (docs/methods.md): every registered solver but `none` on six
// scenes, each to its own end (no frames override), every frame audited, the baselines not stopped.
TEST(SweepSpec, TheMethodsSweepRunsEverySolverThatKeepsPairsApartToTheEnd) {
  const auto s = ccfr::io::load_sweep_spec(cfg("sweeps/methods.yaml"));
  auto expected = ccfr::registered_contact_solvers();
  expected.erase(std::remove(expected.begin(), expected.end(), "none"), expected.end());
  auto got = s.solvers;
  std::sort(got.begin(), got.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(got, expected);
  EXPECT_EQ(s.configs.size(), 6u);
  for (const auto& c : s.configs) EXPECT_TRUE(fs::exists(c)) << c;
  EXPECT_EQ(s.frames, -1);
  EXPECT_EQ(s.audit_stride, 1);
  EXPECT_EQ(s.cell_time_limit_s, 45 * 60.0);  // the comparison's budget per cell (docs/results.md)
  EXPECT_NE(std::find(s.set.begin(), s.set.end(), "contact.on_violation=warn"), s.set.end());
  EXPECT_EQ(s.cells.size(), 6 * expected.size());
}

TEST(SweepSpec, ThePaperSmokeSweepIsThePaperSweepInThreeAuditedFrames) {
  const auto full = ccfr::io::load_sweep_spec(cfg("sweeps/paper.yaml"));
  const auto smoke = ccfr::io::load_sweep_spec(cfg("sweeps/paper_smoke.yaml"));
  EXPECT_EQ(smoke.configs, full.configs);
  EXPECT_EQ(smoke.solvers, full.solvers);
  ASSERT_EQ(smoke.cells.size(), full.cells.size());
  for (size_t i = 0; i < smoke.cells.size(); ++i) EXPECT_EQ(smoke.cells[i].id, full.cells[i].id);
  EXPECT_EQ(smoke.frames, 3);
  EXPECT_EQ(smoke.audit_stride, 1);
  EXPECT_EQ(smoke.resources.cpus_per_task, 1);
}

TEST(SweepSpec, BadSpecsNameFileKeyAndLine) {
  const fs::path d = ccfr::test::scratch_dir("sweep_spec_bad");
  const fs::path spec = d / "bad.yaml";
  const std::string c = "configs: [" + cfg("drape.yaml") + "]\n";
  expect_refused(spec, c + "solver: [ccfr]\n", {spec.string() + ":2:", "solver", "unknown key 'solver'"});
  expect_refused(spec, c + "parameters:\n  contact.offset: [0.01, 0.02]\n  contact.radius: [0.005]\ncombine: zip\n",
                 {spec.string() + ":4:", "parameters.contact.radius", "zip needs lists of one length"});
  expect_refused(spec, c + "solvers: []\n", {"solvers", "empty list"});
  expect_refused(spec, "configs: [missing.yaml]\n", {"configs", "does not exist"});
  expect_refused(spec, c + "resources: {cpus: 2}\n", {"resources.cpus", "unknown key"});
  expect_refused(spec, c + "frames: -1\n", {"frames", "must be >= 0"});
  expect_refused(spec, "", {"expected a map"});
  expect_refused(spec, c + "solvers: [ccfr, ccfr]\n", {"share the id"});
  expect_refused(spec, c + "cell_time_limit: 1:2:3:4\n", {spec.string() + ":2:", "cell_time_limit", "'1:2:3:4'"});
  expect_refused(spec, c + "cell_time_limit: 0\n", {"cell_time_limit", "positive duration"});
  // One value written three ways would run three identical cells.
  expect_refused(spec, c + "parameters:\n  contact.offset: [1.0e-2, 0.01, 0.010]\n",
                 {spec.string() + ":3:", "parameters.contact.offset[1]", "'0.01' is the value of [0] ('1.0e-2')"});
  // In zip, only a pair repeated in every list.
  expect_refused(spec,
                 c + "parameters:\n  contact.offset: [0.01, 0.02, 1e-2]\n  contact.radius: [0.005, 0.005, 0.005]\n"
                     "combine: zip\n",
                 {"parameters.contact.offset[2]", "again in every list"});
  write(spec, c + "parameters:\n  contact.offset: [0.01, 0.02]\n  contact.radius: [0.005, 0.005]\ncombine: zip\n");
  EXPECT_EQ(ccfr::io::load_sweep_spec(spec).cells.size(), 2u);
  // Cases as in a grid: a case given twice, however its values are written, is refused where it is.
  expect_refused(spec, c + "cases:\n  - {contact.offset: 0.01}\n  - {contact.offset: 1e-2}\n",
                 {spec.string() + ":4:", "'cases[1]'", "repeats cases[0]"});
  expect_refused(spec, c + "cases: [{}, {}]\n", {spec.string() + ":2:", "'cases[1]'", "repeats cases[0]"});
  // combine is how parameter lists make cases; cases are listed one by one.
  expect_refused(spec, c + "cases: [{contact.offset: 0.01}]\ncombine: zip\n",
                 {spec.string() + ":3:", "'combine'", "only with parameters"});
}

// Slurm's --time forms, each against its value in seconds worked out by hand; anything else is -1.
TEST(SweepSpec, CellTimeLimitReadsSlurmDurations) {
  using ccfr::io::parse_slurm_duration;
  EXPECT_EQ(parse_slurm_duration("45"), 2700.0);
  EXPECT_EQ(parse_slurm_duration("45:30"), 2730.0);
  EXPECT_EQ(parse_slurm_duration("1:30:00"), 5400.0);
  EXPECT_EQ(parse_slurm_duration("0:00:01"), 1.0);
  EXPECT_EQ(parse_slurm_duration("2-3"), 183600.0);        // (2 x 24 + 3) h
  EXPECT_EQ(parse_slurm_duration("2-3:04"), 183840.0);     // + 4 min
  EXPECT_EQ(parse_slurm_duration("2-3:04:05"), 183845.0);  // + 5 s
  EXPECT_EQ(parse_slurm_duration("0"), 0.0);               // valid form; the spec refuses it as not positive
  for (const char* bad : {"", "a", "1.5", "-5", "1-", "-1:00", "1:2:3:4", "1::2", "1-2:3:4:5", " 5", "5 ", "1-2-3"})
    EXPECT_EQ(parse_slurm_duration(bad), -1.0) << "'" << bad << "'";
  const fs::path d = ccfr::test::scratch_dir("sweep_spec_time_limit");
  write(d / "s.yaml", "configs: [" + cfg("drape.yaml") + "]\ncell_time_limit: \"0:45:00\"\n");
  EXPECT_EQ(ccfr::io::load_sweep_spec(d / "s.yaml").cell_time_limit_s, 2700.0);
}

TEST(Sweep, LocalCellsEqualHandRunsAndResumeRunsWhatIsMissing) {
  const fs::path d = ccfr::test::scratch_dir("sweep_local");
  write(d / "s.yaml", "configs: [" + cfg("stress/cloth_near_floor.yaml") +
                          "]\nsolvers: [ccfr, post_process]\nparameters:\n  contact.offset: [0.008, 0.01]\nframes: 3\n"
                          "set: {contact.on_violation: warn}\n");
  const fs::path out = d / "sweep";
  auto r = run_ccfr("sweep '" + (d / "s.yaml").string() + "' --out '" + out.string() + "' --jobs 2");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("sweep: [4/4]"), std::string::npos) << r.out;

  // One cell against the same run by hand: identical frames.
  const std::string id = "cloth_near_floor__post_process__contact.offset=0.01";
  r = run_ccfr("run '" + cfg("stress/cloth_near_floor.yaml") +
               "' --frames 3 --solver post_process --set contact.offset=0.01 "
               "--set contact.on_violation=warn --out '" +
               (d / "by_hand").string() + "' --log-level warn");
  ASSERT_EQ(r.code, 0) << r.out;
  for (int f = 0; f <= 3; ++f) {
    const std::string n = "frames/frame_0000" + std::to_string(f) + ".obj";
    EXPECT_EQ(read_text(out / id / n), read_text(d / "by_hand" / n)) << n;
  }

  r = run_ccfr("sweep collect '" + out.string() + "' --no-plot");
  ASSERT_EQ(r.code, 0) << r.out;
  std::istringstream csv(read_text(out / "sweep.csv"));
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("cell,scene,solver,contact.offset,halting_percent,frames,status,avg_frame_s", 0), 0u)
      << header;
  int rows = 0;
  while (std::getline(csv, line)) {
    ++rows;
    EXPECT_NE(line.find(",3,completed,"), std::string::npos) << line;
    EXPECT_NE(line.find(",pass,"), std::string::npos) << line;
  }
  EXPECT_EQ(rows, 4);
  EXPECT_NE(read_text(out / "sweep.md").find("| cloth_near_floor | `post_process` | 0.01 | completed | 3 |"),
            std::string::npos);

  // The work and the passes per frame: the means of the cell's own stats.csv columns.
  const auto fields = [](const std::string& row) {
    std::vector<std::string> f;
    std::stringstream ss(row);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    return f;
  };
  const auto mean_of = [&](const fs::path& stats, const std::string& column) {
    std::istringstream in(read_text(stats));
    std::string l;
    std::getline(in, l);
    const auto h = fields(l);
    const size_t c = std::find(h.begin(), h.end(), column) - h.begin();
    double sum = 0;
    int n = 0;
    while (std::getline(in, l)) sum += std::stod(fields(l).at(c)), ++n;
    return sum / n;
  };
  const auto head = fields(header);
  const size_t c_cpu = std::find(head.begin(), head.end(), "cpu_frame_s") - head.begin(),
               c_it = std::find(head.begin(), head.end(), "outer_iterations") - head.begin();
  ASSERT_LT(c_cpu, head.size()) << header;
  ASSERT_LT(c_it, head.size()) << header;
  std::istringstream again(read_text(out / "sweep.csv"));
  std::getline(again, line);
  int checked = 0;
  while (std::getline(again, line)) {
    const auto f = fields(line);
    const fs::path stats = out / f[0] / "stats.csv";
    EXPECT_NEAR(std::stod(f[c_cpu]), mean_of(stats, "cpu_s"), 1e-6) << line;
    EXPECT_NEAR(std::stod(f[c_it]), mean_of(stats, "outer_iterations"), 1e-3) << line;
    EXPECT_GE(std::stod(f[c_it]), 1.0) << line;
    ++checked;
  }
  EXPECT_EQ(checked, 4);

  // A lost cell: status says so, resume runs it (and only it) again.
  fs::remove_all(out / id);
  r = run_ccfr("sweep status '" + out.string() + "'");
  EXPECT_NE(r.out.find("4 cells: 3 completed, 1 not started\n"), std::string::npos) << r.out;
  r = run_ccfr("sweep resume '" + out.string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("resuming " + id + " (not started)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[1/1]"), std::string::npos) << r.out;
  EXPECT_EQ(read_text(out / id / "frames/frame_00003.obj"), read_text(d / "by_hand/frames/frame_00003.obj"));
  r = run_ccfr("sweep resume '" + out.string() + "'");
  EXPECT_NE(r.out.find("nothing to resume"), std::string::npos) << r.out;

  // Another spec into the same directory is refused.
  write(d / "other.yaml", "configs: [" + cfg("stress/cloth_near_floor.yaml") + "]\n");
  r = run_ccfr("sweep '" + (d / "other.yaml").string() + "' --out '" + out.string() + "'");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("holds another sweep"), std::string::npos) << r.out;
}

TEST(Sweep, AblateIsTheSolversOnlySweepAndRefusesSolver) {
  const fs::path d = ccfr::test::scratch_dir("sweep_ablate");
  auto r = run_ccfr("ablate '" + cfg("stress/cloth_near_floor.yaml") + "' --frames 2 --solver ccfr --out '" +
                    (d / "a").string() + "'");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--solver 'ccfr' would be ignored"), std::string::npos) << r.out;
  r = run_ccfr("ablate '" + cfg("stress/cloth_near_floor.yaml") + "' --frames 2 --solvers ccfr,none --no-plot --out '" +
               (d / "a").string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string csv = read_text(d / "a" / "ablation.csv");
  EXPECT_EQ(csv.rfind("solver,frames,status,avg_frame_s", 0), 0u) << csv;
  EXPECT_NE(csv.find("\nccfr,2,completed,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nnone,2,completed,"), std::string::npos) << csv;
  EXPECT_TRUE(fs::exists(d / "a" / "ccfr" / "audit.json"));
  EXPECT_TRUE(fs::exists(d / "a" / "sweep.json"));
  EXPECT_EQ(nlohmann::json::parse(read_text(d / "a" / "ccfr" / "audit.json"))["verdict"], "pass");
}

// A cell whose scene stopped loading after it completed: run-cell runs it again, is refused, and
// says so in its record instead of leaving the earlier attempt's "completed" there; its frames stay
// whole, and its log keeps both attempts (appended).
TEST(Sweep, ACellRefusedOnRerunRecordsTheErrorAndKeepsItsFrames) {
  const fs::path d = ccfr::test::scratch_dir("sweep_refused_rerun");
  const std::string scene = read_text(cfg("stress/cloth_near_floor.yaml"));
  write(d / "scene.yaml", scene);
  const fs::path out = d / "a";
  auto r = run_ccfr("ablate '" + (d / "scene.yaml").string() + "' --frames 2 --solvers post_process --no-plot --out '" +
                    out.string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string frame = read_text(out / "post_process" / "frames" / "frame_00002.obj");
  ASSERT_FALSE(frame.empty());
  const fs::path record = out / "logs" / "post_process.json", log = out / "logs" / "post_process.log";
  EXPECT_EQ(nlohmann::json::parse(read_text(record))["status"], "completed");
  // Run directly, as a Slurm task would; the ablation's own cell log is appended to by the runner.
  r = run_ccfr("sweep run-cell '" + out.string() + "' 0 --threads 1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("completed earlier with this configuration; auditing its frames again"), std::string::npos)
      << r.out;

  write(d / "scene.yaml", scene + "\nnot_a_section: 1\n");
  r = run_ccfr("sweep run-cell '" + out.string() + "' 0 --threads 1");
  EXPECT_EQ(r.code, 2) << r.out;
  const auto rec = nlohmann::json::parse(read_text(record));
  const std::string status = rec["status"];
  EXPECT_EQ(status.rfind("error: ", 0), 0u) << status;
  EXPECT_NE(status.find("not_a_section"), std::string::npos) << status;
  EXPECT_EQ(rec["exit_code"], 2);
  EXPECT_EQ(read_text(out / "post_process" / "frames" / "frame_00002.obj"), frame);

  // The runner appends: an ablation rerun (with the scene repaired) keeps the first attempt's lines.
  const std::string first_log = read_text(log);
  ASSERT_FALSE(first_log.empty());
  write(d / "scene.yaml", scene);
  r = run_ccfr("ablate '" + (d / "scene.yaml").string() + "' --frames 2 --solvers post_process --no-plot --out '" +
               out.string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string both = read_text(log);
  EXPECT_EQ(both.rfind(first_log, 0), 0u) << both;
  EXPECT_GT(both.size(), first_log.size());
  EXPECT_EQ(nlohmann::json::parse(read_text(record))["status"], "completed");
}

// cell_time_limit: a cell still running at the limit stops at the end of its frame, keeps a
// checkpoint, and is audited as far as it ran; status and `sweep status` say it timed out.
TEST(Sweep, ACellStopsAtTheSpecsTimeLimitAndIsAuditedAsFarAsItRan) {
  const fs::path d = ccfr::test::scratch_dir("sweep_time_limit");
  const int frames = 5000;  // far more than one second of cloth_near_floor on any machine
  write(d / "s.yaml", "configs: [" + cfg("stress/cloth_near_floor.yaml") + "]\nsolvers: [ccfr]\nframes: " +
                          std::to_string(frames) + "\ncell_time_limit: \"0:01\"\nset: {output.checkpoint_every: 1}\n");
  const fs::path out = d / "sweep";
  auto r = run_ccfr("sweep '" + (d / "s.yaml").string() + "' --out '" + out.string() + "' --threads 1");
  EXPECT_EQ(r.code, 1) << r.out;
  const std::string id = "cloth_near_floor__ccfr";
  EXPECT_EQ(nlohmann::json::parse(read_text(out / "sweep.json"))["cell_time_limit_s"], 1.0);
  const auto run = nlohmann::json::parse(read_text(out / id / "run.json"));
  const std::string status = run["status"];
  EXPECT_EQ(status.rfind("stopped at its time limit of 1.00 s after frame ", 0), 0u) << status;
  const int last = std::stoi(status.substr(status.rfind(' ') + 1));
  EXPECT_GE(last, 1);
  EXPECT_LT(last, frames);
  EXPECT_EQ(run["frames_written"], last + 1);
  const auto rec = nlohmann::json::parse(read_text(out / "logs" / (id + ".json")));
  EXPECT_EQ(rec["status"], status);
  EXPECT_EQ(rec["audit"], "incomplete");  // clean as far as it ran
  EXPECT_TRUE(fs::exists(out / id / "audit.json"));
  EXPECT_FALSE(fs::is_empty(out / id / "checkpoints"));
  r = run_ccfr("sweep status '" + out.string() + "'");
  EXPECT_NE(r.out.find("timeout"), std::string::npos) << r.out;
}

namespace {

// A stand-in for every Slurm command ccfr calls, in BIN (a host's own Slurm, without a cluster at
// SLURM_CONF, retries for 60 s): sbatch prints job 4242; squeue fails like the real one when
// SLURM_CONF is unset and otherwise prints BIN/queue; sacct fails (no accounting); scontrol shows
// Slurm's default MaxArraySize.
void write_fake_slurm(const fs::path& bin) {
  fs::create_directories(bin);
  write(bin / "sbatch", "#!/bin/sh\necho 4242\n");
  write(bin / "squeue",
        "#!/bin/sh\n[ -n \"$SLURM_CONF\" ] || { echo 'slurm_load_jobs error: Unable to contact slurm controller'; "
        "exit 1; }\ncat \"$(dirname \"$0\")/queue\"\n");
  write(bin / "sacct", "#!/bin/sh\necho 'Slurm accounting storage is disabled'; exit 1\n");
  write(bin / "scontrol", "#!/bin/sh\necho 'MaxArraySize            = 1001'\n");
  write(bin / "queue", "");
  for (const char* n : {"sbatch", "squeue", "sacct", "scontrol"})
    fs::permissions(bin / n, fs::perms::owner_all, fs::perm_options::replace);
}

// ccfr with BIN first on PATH and SLURM_CONF set to `conf` (unset when empty).
ccfr::test::CliResult run_with_slurm(const fs::path& bin, const std::string& conf, const std::string& args) {
  const std::string env = conf.empty() ? "env -u SLURM_CONF" : "env SLURM_CONF='" + conf + "'";
  return ccfr::test::run_shell(env + " PATH='" + bin.string() + "':\"$PATH\" " + std::string(CCFR_EXE) + " " + args +
                               " 2>&1");
}

}  // namespace

// A Slurm sweep's status shows each cell's frames on disk, a running task's too (its progress is
// otherwise only in its Slurm log); resume without SLURM_CONF exits 0 when every cell completed and
// names SLURM_CONF when some cell might still be queued or running.
TEST(Sweep, SlurmStatusShowsFramesAndResumeWithoutSlurmConf) {
  const fs::path d = ccfr::test::scratch_dir("sweep_slurm_fake");
  const fs::path bin = d / "bin", out = d / "sweep";
  write_fake_slurm(bin);
  write(d / "s.yaml", "configs: [" + cfg("stress/cloth_near_floor.yaml") +
                          "]\nsolvers: [ccfr, none]\nframes: 3\nset: {contact.on_violation: warn}\n");
  auto r = run_with_slurm(bin, "/fake/slurm.conf",
                          "sweep '" + (d / "s.yaml").string() + "' --out '" + out.string() + "' --backend slurm");
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_NE(r.out.find("submitted job 4242"), std::string::npos) << r.out;
  // What the two array tasks would run.
  for (int i = 0; i < 2; ++i) {
    r = run_ccfr("sweep run-cell '" + out.string() + "' " + std::to_string(i) + " --threads 1");
    ASSERT_EQ(r.code, 0) << r.out;
  }
  const std::string running_id = "cloth_near_floor__none", done_id = "cloth_near_floor__ccfr";

  // Every cell completed: nothing to do, with or without SLURM_CONF.
  r = run_with_slurm(bin, "", "sweep resume '" + out.string() + "'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("nothing to resume"), std::string::npos) << r.out;
  EXPECT_EQ(nlohmann::json::parse(read_text(out / "sweep.json"))["slurm_jobs"].size(), 1u) << "resubmitted";

  // Cell 1 as its task is at frame 1 of 3: run.json says running, stats.csv holds one frame.
  const std::string run_json = read_text(out / running_id / "run.json");
  const std::string stats = read_text(out / running_id / "stats.csv");
  nlohmann::json rj = nlohmann::json::parse(run_json);
  rj["status"] = "running";
  write(out / running_id / "run.json", rj.dump(2));
  std::istringstream lines(stats);
  std::string header, first;
  std::getline(lines, header);
  std::getline(lines, first);
  write(out / running_id / "stats.csv", header + "\n" + first + "\n");
  write(bin / "queue", "4242_1 RUNNING\n");

  r = run_with_slurm(bin, "/fake/slurm.conf", "sweep status '" + out.string() + "'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(running_id), std::string::npos) << r.out;
  const auto row = [&](const std::string& id) {
    const size_t at = r.out.find(id + " ");
    return at == std::string::npos ? std::string() : r.out.substr(at, r.out.find('\n', at) - at);
  };
  EXPECT_NE(row(running_id).find(" running "), std::string::npos) << r.out;
  EXPECT_NE(row(running_id).find(" 1/3"), std::string::npos) << r.out;
  EXPECT_NE(row(done_id).find(" completed "), std::string::npos) << r.out;
  EXPECT_NE(row(done_id).find(" 3/3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frames: 4 of 6 (67 %)"), std::string::npos) << r.out;

  // Without SLURM_CONF squeue fails: status warns naming it, resume refuses naming it.
  r = run_with_slurm(bin, "", "sweep status '" + out.string() + "'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("SLURM_CONF is not set"), std::string::npos) << r.out;
  r = run_with_slurm(bin, "", "sweep resume '" + out.string() + "'");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("1 of the 2 cells"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("SLURM_CONF is not set"), std::string::npos) << r.out;
  EXPECT_EQ(nlohmann::json::parse(read_text(out / "sweep.json"))["slurm_jobs"].size(), 1u) << "resubmitted";

  // With SLURM_CONF and the task gone from the queue, resume resubmits the cell.
  write(bin / "queue", "");
  r = run_with_slurm(bin, "/fake/slurm.conf", "sweep resume '" + out.string() + "'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("resuming " + running_id + " (lost)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("array 1, 1 cells"), std::string::npos) << r.out;
}

// Slurm refuses array indices at or above MaxArraySize (1001 by default): a sweep past the
// cluster's is refused with the reason before anything is written (it submitted --array=0-9999).
TEST(Sweep, ASlurmSweepPastMaxArraySizeIsRefusedBeforeSubmitting) {
  const fs::path d = ccfr::test::scratch_dir("sweep_slurm_array_size");
  const fs::path bin = d / "bin", out = d / "sweep";
  write_fake_slurm(bin);
  write(bin / "scontrol", "#!/bin/sh\necho 'MaxArraySize            = 3'\n");
  fs::permissions(bin / "scontrol", fs::perms::owner_all, fs::perm_options::replace);
  write(d / "s.yaml", "configs: [" + cfg("stress/cloth_near_floor.yaml") +
                          "]\nsolvers: [ccfr, none]\nparameters: {contact.offset: [0.008, 0.01]}\nframes: 1\n");
  auto r = run_with_slurm(bin, "/fake/slurm.conf",
                          "sweep '" + (d / "s.yaml").string() + "' --out '" + out.string() + "' --backend slurm");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("MaxArraySize is 3 (`scontrol show config`)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("task index 3 (4 cells)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("submitted job"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out / "sweep.json")) << r.out;
  // Within it, the same grid submits.
  write(bin / "scontrol", "#!/bin/sh\necho 'MaxArraySize            = 4'\n");
  r = run_with_slurm(bin, "/fake/slurm.conf",
                     "sweep '" + (d / "s.yaml").string() + "' --out '" + out.string() + "' --backend slurm");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("submitted job 4242"), std::string::npos) << r.out;
}
