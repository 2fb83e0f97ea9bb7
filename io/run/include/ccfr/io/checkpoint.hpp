#pragma once
/// @file checkpoint.hpp
/// Checkpoints of a run (docs/output.md, "Checkpoints and --resume"): the state a Simulation needs
/// to continue exactly, the resolved configuration it ran and how it was loaded, in one versioned,
/// checksummed file written atomically to DIR/checkpoints/checkpoint_NNNNN.ccfr.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/solvers/simulation.hpp"

namespace ccfr::io {

/// Format version written into every checkpoint; another version is refused.
inline constexpr std::uint32_t kCheckpointFormat = 1;

struct Checkpoint {
  SimulationCheckpoint sim;
  std::string ccfr_version, git_commit;  ///< of the build that wrote it
  std::string resolved_config;           ///< run.json `config`: every default filled in, as JSON
  std::filesystem::path scene_file;      ///< absolute path of the scene file
  std::vector<std::string> overrides;    ///< --set, --frames and --solver as key.path=value
  std::uint64_t scene_fingerprint = 0;   ///< scene_fingerprint() of the initial scene
  std::vector<double> audit_offsets;     ///< in-simulation audit state (debug.audit), empty if off
  std::int64_t violated_frames = 0;      ///< frames so far that ended with violations (exit code 3)
  std::int32_t frames_written = 0;       ///< frame files on disk at the checkpoint
};

/// CRC-32 (IEEE 802.3, the polynomial of zlib and PNG) of `data`.
std::uint32_t crc32(std::string_view data);

/// FNV-1a over the connectivity (objects, faces, edges, tets) and the initial positions and inverse
/// masses: a scene whose mesh files changed since the checkpoint does not match it.
std::uint64_t scene_fingerprint(const Topology& topo, const SimState& initial);

/// The file's bytes: "CCFRCKPT", format version (u32), payload length (u64), payload, CRC-32 of
/// everything before it (u32); little-endian.
std::string encode_checkpoint(const Checkpoint& c);
/// Parses encode_checkpoint()'s bytes. Throws ccfr::Error naming `file` and what is wrong: not a
/// checkpoint, another format version, truncated (length), corrupted (checksum), inconsistent fields.
Checkpoint decode_checkpoint(std::string_view bytes, const std::filesystem::path& file);

/// DIR/checkpoints/checkpoint_NNNNN.ccfr for frame NNNNN.
std::filesystem::path checkpoint_path(const std::filesystem::path& run_dir, int frame);
/// Writes the checkpoint of frame c.sim.frame atomically, then removes the older ones of DIR.
/// Returns its path; throws ccfr::Error naming the file on a failed write.
std::filesystem::path write_checkpoint(const std::filesystem::path& run_dir, const Checkpoint& c);
/// The checkpoint of DIR with the highest frame number, if any.
std::optional<std::filesystem::path> latest_checkpoint(const std::filesystem::path& run_dir);
/// Reads and decodes a checkpoint file (throws as decode_checkpoint, or if it cannot be read).
Checkpoint read_checkpoint(const std::filesystem::path& file);

/// The first key path where two JSON documents differ ("time.frames: 40 vs 30"), empty if equal.
std::string json_difference(const std::string& a, const std::string& b);

}  // namespace ccfr::io
