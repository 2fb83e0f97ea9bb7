#pragma once
/// @file sweep_spec.hpp
/// Sweep specifications (`ccfr sweep SPEC.yaml`, docs/cluster.md): base configs × contact solvers ×
/// parameter values, expanded into cells with stable ids. Loaded strictly: unknown keys, wrong
/// types and empty lists are ccfr::ConfigError naming the file, key path and line.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace ccfr::io {

/// Slurm resources of one cell (one array task); empty strings are left to the cluster's defaults.
struct SweepResources {
  int cpus_per_task = 1;
  std::string time = "01:00:00";  ///< sbatch --time
  std::string memory;             ///< sbatch --mem, e.g. "2G"
  std::string partition, account;
};

struct SweepCell {
  std::string id;                ///< stable: scene, solver and parameter values, e.g. drape__ccfr__contact.offset=0.01
  std::filesystem::path config;  ///< absolute scene file
  std::string scene;             ///< the scene file's stem
  std::string solver;            ///< empty: the scene's contact.solver
  std::vector<std::pair<std::string, std::string>> params;  ///< swept key path and value, in spec order
  std::vector<std::string> overrides;  ///< every --set of the cell (spec `set`, frames, solver, params)
};

struct SweepSpec {
  std::filesystem::path file;
  std::vector<std::filesystem::path> configs;   ///< absolute
  std::vector<std::string> solvers;             ///< empty: each scene's own solver
  std::vector<std::string> parameter_keys;      ///< swept key paths, in spec order
  std::vector<std::vector<std::string>> cases;  ///< per case, one value per parameter key
  std::vector<std::string> set;                 ///< key.path=value applied to every cell
  int frames = -1;                              ///< -1: each scene's time.frames
  int audit_stride = 1;
  /// cell_time_limit: wall seconds after which a cell stops at the end of its frame, writes its
  /// checkpoint and is audited as far as it ran (both backends); 0: no limit.
  double cell_time_limit_s = 0.0;
  SweepResources resources;
  std::vector<SweepCell> cells;  ///< configs × solvers × cases, in that nesting order
};

/// A duration as Slurm writes --time: minutes ("45"), "MM:SS", "H:MM:SS", "D-H", "D-H:MM" or
/// "D-H:MM:SS"; returns seconds, or -1 when `text` is none of these.
double parse_slurm_duration(const std::string& text);

/// Reads SPEC.yaml (keys: configs, solvers, parameters, combine: product|zip, cases, set, frames,
/// audit_stride, cell_time_limit, resources{cpus_per_task, time, memory, partition, account}) and expands its cells.
/// Config paths are relative to the spec file. Throws ccfr::ConfigError / ccfr::Error.
SweepSpec load_sweep_spec(const std::filesystem::path& file);

/// Cells of `configs` × `solvers` × `cases` (one value per key of `keys`), with `set` and `frames`
/// applied to every cell. `solver_ids_only`: ids are the solver names (ccfr ablate's layout).
std::vector<SweepCell> expand_sweep(const std::vector<std::filesystem::path>& configs,
                                    const std::vector<std::string>& solvers, const std::vector<std::string>& keys,
                                    const std::vector<std::vector<std::string>>& cases,
                                    const std::vector<std::string>& set, int frames, bool solver_ids_only = false);

}  // namespace ccfr::io
