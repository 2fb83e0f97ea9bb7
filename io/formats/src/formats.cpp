#include "ccfr/io/formats.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <zlib.h>
#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "ccfr/core/error.hpp"
#include "ccfr/io/frame_topology.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

std::vector<std::string> output_format_names() { return {"obj", "ply", "vtu", "pc2", "usda"}; }

std::optional<OutputFormat> output_format_from_string(std::string_view name) {
  static const std::pair<std::string_view, OutputFormat> kTable[] = {{"obj", OutputFormat::obj},
                                                                     {"ply", OutputFormat::ply},
                                                                     {"vtu", OutputFormat::vtu},
                                                                     {"pc2", OutputFormat::pc2},
                                                                     {"usda", OutputFormat::usda}};
  for (const auto& [n, f] : kTable)
    if (n == name) return f;
  return std::nullopt;
}

std::vector<OutputFormat> parse_output_formats(const std::vector<std::string>& names) {
  std::vector<OutputFormat> out;
  for (const auto& n : names) {
    const auto f = output_format_from_string(n);
    if (!f) {
      std::string list;
      for (const auto& k : output_format_names()) list += (list.empty() ? "" : ", ") + k;
      throw Error("unknown output format '" + n + "' (supported: " + list + ")");
    }
    if (std::find(out.begin(), out.end(), *f) == out.end()) out.push_back(*f);
  }
  return out;
}

std::string format_folder(OutputFormat format) {
  switch (format) {
    case OutputFormat::obj:
    case OutputFormat::ply:
      return "frames";
    case OutputFormat::vtu:
      return "vtk";
    case OutputFormat::pc2:
      return "blender";
    case OutputFormat::usda:
      return "usd";
  }
  return "frames";
}

namespace {

std::string frame_name(int frame, const char* ext) {
  char name[40];
  std::snprintf(name, sizeof name, "frame_%05d.%s", frame, ext);
  return name;
}

void make_dir(const fs::path& d) {
  std::error_code ec;
  fs::create_directories(d, ec);
  if (ec) throw Error("cannot create directory '" + d.string() + "': " + ec.message());
}

/// A per-frame format on resume: every frame written before the checkpoint must be on disk (else
/// the finished run would have a gap).
void check_frames_before(const fs::path& folder, const char* ext, const ResumedFrames& before) {
  for (int f : before.frames) {
    std::error_code ec;
    const fs::path p = folder / frame_name(f, ext);
    if (!fs::is_regular_file(p, ec))
      throw Error("cannot resume: '" + p.string() + "' (written before the checkpoint of frame " +
                  std::to_string(before.last) + ") is missing; the finished run would have a gap: restore it or run " +
                  "again");
  }
}

/// ... and the frames after it, left by the interrupted run, go.
void keep_frames_before(const fs::path& folder, const char* ext, const ResumedFrames& before) {
  check_frames_before(folder, ext, before);
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder, ec)) {
    const std::string n = e.path().filename().string();
    const std::string suffix = std::string(".") + ext;
    if (n.size() != 11 + suffix.size() || n.rfind("frame_", 0) != 0 || n.substr(11) != suffix) continue;
    const std::string digits = n.substr(6, 5);
    if (digits.find_first_not_of("0123456789") != std::string::npos || std::stoi(digits) <= before.last) continue;
    std::error_code rec;
    fs::remove(e.path(), rec);
    if (rec) throw Error("cannot remove '" + e.path().string() + "': " + rec.message());
  }
}

template <class T>
void append_raw(std::string& s, const T& value) {
  s.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

/// Elements of a frame as the viewers see them: triangles of surfaces (tet solids: their tets),
/// strand polylines, free particles.
struct Cells {
  std::vector<std::int32_t> connectivity, offsets;
  std::vector<std::uint8_t> types;
  std::vector<std::int32_t> object;  ///< per cell
};

// VTK cell type ids (vtkCellType.h).
constexpr std::uint8_t kVtkVertex = 1, kVtkPolyLine = 4, kVtkTriangle = 5, kVtkTetra = 10;

Cells make_cells(const Topology& topo) {
  Cells c;
  auto close = [&](std::uint8_t type, std::int32_t obj) {
    c.offsets.push_back(static_cast<std::int32_t>(c.connectivity.size()));
    c.types.push_back(type);
    c.object.push_back(obj);
  };
  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
    const ObjectInfo& o = topo.objects[oi];
    const auto id = static_cast<std::int32_t>(oi);
    if (o.tet_end > o.tet_begin) {
      for (Index t = o.tet_begin; t < o.tet_end; ++t) {
        for (int k = 0; k < 4; ++k) c.connectivity.push_back(topo.tets[t][k]);
        close(kVtkTetra, id);
      }
    } else {
      for (Index f = o.face_begin; f < o.face_end; ++f) {
        for (int k = 0; k < 3; ++k) c.connectivity.push_back(topo.faces[f][k]);
        close(kVtkTriangle, id);
      }
    }
    for (Index l = o.polyline_begin; l < o.polyline_end; ++l) {
      for (Index v : topo.polylines.row(l)) c.connectivity.push_back(v);
      close(kVtkPolyLine, id);
    }
    if (o.kind == ObjectKind::particles)
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
        c.connectivity.push_back(v);
        close(kVtkVertex, id);
      }
  }
  return c;
}

// ---------------------------------------------------------------------------------------------
// Binary PLY: float positions, triangle faces, strand segments as `edge` elements.
class PlySink final : public FrameSink {
 public:
  explicit PlySink(const Topology& topo) : topo_(topo) {
    for (Index l = 0; l < topo.polylines.rows(); ++l) {
      const auto row = topo.polylines.row(l);
      for (size_t k = 1; k < row.size(); ++k) segments_.push_back({row[k - 1], row[k]});
    }
  }
  void write(const fs::path& dir, int frame, double, const Positions& x, const VertexFields&) override {
    std::string s = "ply\nformat binary_little_endian 1.0\ncomment ccfr frame " + std::to_string(frame) + "\n";
    s += "element vertex " + std::to_string(x.size()) + "\nproperty float x\nproperty float y\nproperty float z\n";
    s += "element face " + std::to_string(topo_.faces.size()) + "\nproperty list uchar int vertex_indices\n";
    if (!segments_.empty())
      s += "element edge " + std::to_string(segments_.size()) + "\nproperty int vertex1\nproperty int vertex2\n";
    s += "end_header\n";
    s.reserve(s.size() + x.size() * 12 + topo_.faces.size() * 13 + segments_.size() * 8);
    for (const Vec3& p : x)
      for (int k = 0; k < 3; ++k) append_raw(s, static_cast<float>(p[k]));
    for (const Vec3i& f : topo_.faces) {
      append_raw(s, std::uint8_t{3});
      for (int k = 0; k < 3; ++k) append_raw(s, static_cast<std::int32_t>(f[k]));
    }
    for (const auto& e : segments_) {
      append_raw(s, static_cast<std::int32_t>(e[0]));
      append_raw(s, static_cast<std::int32_t>(e[1]));
    }
    make_dir(dir / "frames");
    write_file_atomic(dir / "frames" / frame_name(frame, "ply"), s);
  }
  // One file per frame: the frames before the checkpoint are already as an uninterrupted run left them.
  void resume(const fs::path& dir, const ResumedFrames& before) override {
    keep_frames_before(dir / "frames", "ply", before);
  }

 private:
  const Topology& topo_;
  std::vector<std::array<Index, 2>> segments_;
};

/// One array of VTK's zlib-compressed appended data: the UInt64 header [#blocks, block size, size
/// of the last block, compressed size of each block], then the compressed blocks. The topology,
/// repeated in every frame, compresses about tenfold.
void append_compressed(std::string& out, const char* bytes, size_t size) {
  constexpr size_t kBlock = size_t{1} << 16;
  const size_t blocks = (size + kBlock - 1) / kBlock;
  const size_t header_at = out.size();
  append_raw(out, static_cast<std::uint64_t>(blocks));
  append_raw(out, static_cast<std::uint64_t>(kBlock));
  append_raw(out, static_cast<std::uint64_t>(blocks == 0 || size % kBlock == 0 ? 0 : size % kBlock));
  for (size_t b = 0; b < blocks; ++b) append_raw(out, std::uint64_t{0});
  for (size_t b = 0; b < blocks; ++b) {
    const size_t n = std::min(kBlock, size - b * kBlock);
    uLongf clen = compressBound(static_cast<uLong>(n));
    const size_t at = out.size();
    out.resize(at + clen);
    if (compress2(reinterpret_cast<Bytef*>(&out[at]), &clen, reinterpret_cast<const Bytef*>(bytes + b * kBlock),
                  static_cast<uLong>(n), Z_DEFAULT_COMPRESSION) != Z_OK)
      throw Error("zlib could not compress a VTU array");
    out.resize(at + clen);
    const std::uint64_t c = clen;
    std::memcpy(&out[header_at + 8 * (3 + b)], &c, sizeof c);
  }
}

// ---------------------------------------------------------------------------------------------
// VTK XML UnstructuredGrid, zlib-compressed binary appended data (UInt64 headers), and a PVD collection.
class VtuSink final : public FrameSink {
 public:
  explicit VtuSink(const Topology& topo) : topo_(topo), cells_(make_cells(topo)) {
    for (Index v = 0; v < topo.num_vertices(); ++v) object_.push_back(static_cast<std::int32_t>(topo.vertex_object[v]));
  }
  void write(const fs::path& dir, int frame, double time, const Positions& x, const VertexFields& f) override {
    const size_t nv = x.size();
    std::string xml, data;
    auto array = [&](const char* type, const char* name, int comps, const void* bytes, size_t size) {
      xml += std::string("        <DataArray type=\"") + type + "\" Name=\"" + name + "\"";
      if (comps > 1) xml += " NumberOfComponents=\"" + std::to_string(comps) + "\"";
      xml += " format=\"appended\" offset=\"" + std::to_string(data.size()) + "\"/>\n";
      append_compressed(data, static_cast<const char*>(bytes), size);
    };
    std::vector<float> pts(3 * nv);
    for (size_t v = 0; v < nv; ++v)
      for (int k = 0; k < 3; ++k) pts[3 * v + k] = static_cast<float>(x[v][k]);
    xml +=
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
        "header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">\n  <UnstructuredGrid>\n";
    xml += "    <Piece NumberOfPoints=\"" + std::to_string(nv) + "\" NumberOfCells=\"" +
           std::to_string(cells_.types.size()) + "\">\n";
    xml += "      <PointData>\n";
    if (f.velocity.size() == nv) {
      std::vector<float> vel(3 * nv);
      for (size_t v = 0; v < nv; ++v)
        for (int k = 0; k < 3; ++k) vel[3 * v + k] = static_cast<float>(f.velocity[v][k]);
      array("Float32", "velocity", 3, vel.data(), vel.size() * sizeof(float));
    }
    array("Int32", "object_id", 1, object_.data(), object_.size() * sizeof(std::int32_t));
    if (f.halted.size() == nv) array("UInt8", "halted", 1, f.halted.data(), nv);
    if (f.half_spaces.size() == nv) array("Int32", "half_spaces", 1, f.half_spaces.data(), nv * sizeof(std::int32_t));
    if (f.distance.size() == nv) {
      std::vector<float> d(f.distance.begin(), f.distance.end());
      array("Float32", "distance", 1, d.data(), nv * sizeof(float));
    }
    xml += "      </PointData>\n      <CellData>\n";
    array("Int32", "object_id", 1, cells_.object.data(), cells_.object.size() * sizeof(std::int32_t));
    xml += "      </CellData>\n      <Points>\n";
    array("Float32", "Points", 3, pts.data(), pts.size() * sizeof(float));
    xml += "      </Points>\n      <Cells>\n";
    array("Int32", "connectivity", 1, cells_.connectivity.data(), cells_.connectivity.size() * sizeof(std::int32_t));
    // VTK's offsets are the ends of the cells.
    std::vector<std::int32_t> ends(cells_.offsets.size());
    for (size_t c = 0; c < ends.size(); ++c)
      ends[c] = c + 1 < ends.size() ? cells_.offsets[c + 1] : static_cast<std::int32_t>(cells_.connectivity.size());
    array("Int32", "offsets", 1, ends.data(), ends.size() * sizeof(std::int32_t));
    array("UInt8", "types", 1, cells_.types.data(), cells_.types.size());
    xml += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";
    xml += data;
    xml += "\n  </AppendedData>\n</VTKFile>\n";
    make_dir(dir / "vtk");
    const std::string name = frame_name(frame, "vtu");
    write_file_atomic(dir / "vtk" / name, xml);
    add_entry(frame, time);
    write_file_atomic(dir / "vtk" / "frames.pvd",
                      "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" "
                      "byte_order=\"LittleEndian\">\n  <Collection>\n" +
                          entries_ + "  </Collection>\n</VTKFile>\n");
  }
  // The .vtu files before the checkpoint carry the solver's point data (halted, half_spaces,
  // distance), which OBJ frames do not hold: they are kept, and the collection lists them again.
  void resume(const fs::path& dir, const ResumedFrames& before) override {
    keep_frames_before(dir / "vtk", "vtu", before);
    entries_.clear();
    for (int f : before.frames) add_entry(f, before.fps > 0 ? f / before.fps : 0.0);
  }

 private:
  void add_entry(int frame, double time) {
    char t[40];
    std::snprintf(t, sizeof t, "%.17g", time);
    entries_ +=
        std::string("    <DataSet timestep=\"") + t + "\" part=\"0\" file=\"" + frame_name(frame, "vtu") + "\"/>\n";
  }
  const Topology& topo_;
  Cells cells_;
  std::vector<std::int32_t> object_;
  std::string entries_;
};

// ---------------------------------------------------------------------------------------------
// PC2 point caches (one per object) + the first frame as OBJ + a manifest for import_blender.py.

/// A file name for an object: index and the name with anything but [A-Za-z0-9_-] replaced.
std::string file_stem(size_t index, const std::string& name) {
  char prefix[16];
  std::snprintf(prefix, sizeof prefix, "%03zu_", index);
  std::string s = prefix;
  for (unsigned char c : name) s += std::isalnum(c) || c == '_' || c == '-' ? static_cast<char>(c) : '_';
  return s;
}

/// What resume needs of a PC2 cache written by Pc2Sink: the samples it holds whole (its header's
/// count, as far as the file is that long), or why it is not one of this run's (`problem`).
struct Pc2Header {
  int count = 0;
  std::string problem;
};

Pc2Header read_pc2_header(const fs::path& p, Index nv) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return {0, "'" + p.string() + "' is missing"};
  char h[32];
  if (!in.read(h, sizeof h) || std::memcmp(h, "POINTCACHE2\0", 12) != 0)
    return {0, "'" + p.string() + "' does not start with a PC2 header"};
  std::int32_t version = 0, points = 0, count = 0;
  std::memcpy(&version, h + 12, 4);
  std::memcpy(&points, h + 16, 4);
  std::memcpy(&count, h + 28, 4);
  if (version != 1 || points != nv)
    return {0, "'" + p.string() + "' holds " + std::to_string(points) + " points per sample, the object has " +
                   std::to_string(nv)};
  std::error_code ec;
  const auto size = fs::file_size(p, ec);
  if (ec) return {0, "cannot read '" + p.string() + "': " + ec.message()};
  const long long whole = nv > 0 ? static_cast<long long>((size - 32) / (12 * static_cast<std::uintmax_t>(nv))) : count;
  return {static_cast<int>(std::min<long long>(std::max(count, 0), whole)), ""};
}

/// Sample `k` of the PC2 caches of `blender` (one per object), as positions of the whole run.
Positions read_pc2_sample(const fs::path& blender, const Topology& topo, size_t k) {
  Positions x(static_cast<size_t>(topo.num_vertices()), Vec3::Zero());
  for (size_t i = 0; i < topo.objects.size(); ++i) {
    const ObjectInfo& o = topo.objects[i];
    const fs::path p = blender / (file_stem(i, o.name) + ".pc2");
    const Pc2Header h = read_pc2_header(p, o.num_vertices());
    if (!h.problem.empty()) throw Error("cannot resume: " + h.problem);
    if (static_cast<size_t>(h.count) <= k)
      throw Error("cannot resume: '" + p.string() + "' holds " + std::to_string(h.count) + " whole samples, sample " +
                  std::to_string(k) + " is needed");
    std::ifstream in(p, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(32 + k * 12 * static_cast<size_t>(o.num_vertices())));
    for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
      float c[3];
      if (!in.read(reinterpret_cast<char*>(c), sizeof c)) throw Error("cannot read '" + p.string() + "'");
      x[v] = Vec3(c[0], c[1], c[2]);
    }
  }
  return x;
}

class Pc2Sink final : public FrameSink {
 public:
  Pc2Sink(const Topology& topo, double fps, int every) : topo_(topo), fps_(fps), every_(every) {}
  void write(const fs::path& dir, int frame, double, const Positions& x, const VertexFields&) override {
    const fs::path b = dir / "blender";
    if (samples_ == 0) {
      make_dir(b);
      write_frame_obj(b / "first_frame.obj", topo_, x);
      nlohmann::ordered_json m;
      m["fps"] = fps_;
      m["every"] = every_;
      m["first_frame"] = "first_frame.obj";
      m["start_frame"] = frame;
      auto& objs = m["objects"] = nlohmann::ordered_json::array();
      for (size_t i = 0; i < topo_.objects.size(); ++i) {
        const ObjectInfo& o = topo_.objects[i];
        objs.push_back({{"name", o.name},
                        {"kind", std::string(to_string(o.kind))},
                        {"pc2", file_stem(i, o.name) + ".pc2"},
                        {"vertex_begin", o.vertex_begin},
                        {"vertex_end", o.vertex_end}});
        std::string h("POINTCACHE2\0", 12);
        append_raw(h, std::int32_t{1});
        append_raw(h, static_cast<std::int32_t>(o.num_vertices()));
        append_raw(h, static_cast<float>(frame));
        append_raw(h, static_cast<float>(every_));
        append_raw(h, std::int32_t{0});
        write_file_atomic(b / (file_stem(i, o.name) + ".pc2"), h);
      }
      write_file_atomic(b / "manifest.json", m.dump(2) + "\n");
    }
    for (size_t i = 0; i < topo_.objects.size(); ++i) {
      const ObjectInfo& o = topo_.objects[i];
      std::string s;
      s.reserve(12 * static_cast<size_t>(o.num_vertices()));
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v)
        for (int k = 0; k < 3; ++k) append_raw(s, static_cast<float>(x[v][k]));
      append(b / (file_stem(i, o.name) + ".pc2"), s, samples_ + 1, o.num_vertices());
    }
    ++samples_;
  }
  // The caches are appended sample by sample: cut back to the samples before the checkpoint
  // (count first, so the file never counts more than it holds), or, if they are not whole, written
  // again from the frames on disk.
  void resume(const fs::path& dir, const ResumedFrames& before) override {
    samples_ = 0;
    if (before.frames.empty()) return;
    const fs::path b = dir / "blender";
    const int n = static_cast<int>(before.frames.size());
    std::string problem;
    std::error_code ec;
    for (const char* f : {"manifest.json", "first_frame.obj"})
      if (problem.empty() && !fs::is_regular_file(b / f, ec)) problem = "'" + (b / f).string() + "' is missing";
    for (size_t i = 0; i < topo_.objects.size() && problem.empty(); ++i) {
      const fs::path p = b / (file_stem(i, topo_.objects[i].name) + ".pc2");
      const Pc2Header h = read_pc2_header(p, topo_.objects[i].num_vertices());
      problem = h.problem;
      if (problem.empty() && h.count < n)
        problem = "'" + p.string() + "' holds " + std::to_string(h.count) + " whole samples, the run had written " +
                  std::to_string(n) + " frames before its checkpoint of frame " + std::to_string(before.last);
    }
    if (problem.empty()) {
      for (size_t i = 0; i < topo_.objects.size(); ++i) {
        const fs::path p = b / (file_stem(i, topo_.objects[i].name) + ".pc2");
        const std::int32_t count = n;
        const int fd = ::open(p.c_str(), O_WRONLY | O_CLOEXEC);
        const bool ok = fd >= 0 && ::pwrite(fd, &count, sizeof count, 28) == sizeof count &&
                        ::ftruncate(fd, 32 + static_cast<off_t>(n) * 12 * topo_.objects[i].num_vertices()) == 0;
        const int err = errno;
        if (fd >= 0) ::close(fd);
        if (!ok) throw Error("cannot write '" + p.string() + "': " + std::strerror(err));
      }
      samples_ = n;
      return;
    }
    if (!before.positions)
      throw Error("cannot resume: " + problem + "; without OBJ frames (output.formats has no obj) the point caches " +
                  "cannot be rebuilt: run again");
    replay_frames({this}, dir, before.frames, before.positions, before.fps, false);
  }

 private:
  /// Appends one sample after the `samples_` already counted, then raises the header's count: a
  /// file cut short by a crash holds whole samples up to its count.
  void append(const fs::path& p, const std::string& bytes, int count, Index nv) {
    const int fd = ::open(p.c_str(), O_WRONLY | O_CLOEXEC);
    auto fail = [&](int err) {
      if (fd >= 0) ::close(fd);
      throw Error("cannot write '" + p.string() + "': " + std::strerror(err));
    };
    if (fd < 0) fail(errno);
    const off_t at = 32 + static_cast<off_t>(samples_) * 12 * nv;
    if (::pwrite(fd, bytes.data(), bytes.size(), at) != static_cast<ssize_t>(bytes.size())) fail(errno ? errno : EIO);
    const std::int32_t n = count;
    if (::pwrite(fd, &n, sizeof n, 28) != sizeof n) fail(errno ? errno : EIO);
    if (::close(fd) != 0) fail(errno);
  }

  const Topology& topo_;
  double fps_;
  int every_;
  int samples_ = 0;
};

// ---------------------------------------------------------------------------------------------
// USDA: one prim per object, topology once, `points.timeSamples` keyed by frame number.

/// A USD prim name: [A-Za-z_][A-Za-z0-9_]*, unique in the scene.
std::string prim_name(const std::string& name, std::set<std::string>& used) {
  std::string s;
  for (unsigned char c : name) s += std::isalnum(c) || c == '_' ? static_cast<char>(c) : '_';
  if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) s = "_" + s;
  std::string u = s;
  for (int k = 1; !used.insert(u).second; ++k) u = s + "_" + std::to_string(k);
  return u;
}

/// The USDA samples file of a run with neither obj nor pc2: "CCFRUSD1", the vertex count (uint32),
/// then per frame its number (int32) and 3 n float32 positions, appended as the frames come.
constexpr char kUsdaSamplesMagic[8] = {'C', 'C', 'F', 'R', 'U', 'S', 'D', '1'};
fs::path usda_samples_path(const fs::path& dir) { return dir / "usd" / "scene.usda.samples"; }

void start_usda_samples(const fs::path& dir, std::uint32_t n) {
  make_dir(dir / "usd");
  std::ofstream out(usda_samples_path(dir), std::ios::binary | std::ios::trunc);
  out.write(kUsdaSamplesMagic, sizeof kUsdaSamplesMagic);
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  if (!out) throw Error("cannot write '" + usda_samples_path(dir).string() + "'");
}

/// The samples of `frames` from DIR's USDA samples file, in that order; throws naming the file if
/// it is missing, of another vertex count, or lacks one of them.
std::vector<std::vector<float>> read_usda_samples(const fs::path& dir, const std::vector<int>& frames,
                                                  std::uint32_t n) {
  const fs::path p = usda_samples_path(dir);
  std::ifstream in(p, std::ios::binary);
  char magic[8];
  std::uint32_t count = 0;
  if (!in || !in.read(magic, sizeof magic) || !std::equal(magic, magic + 8, kUsdaSamplesMagic) ||
      !in.read(reinterpret_cast<char*>(&count), sizeof count))
    throw Error("cannot resume '" + dir.string() + "': its USDA layer is rebuilt from '" + p.string() +
                "' (output.formats has neither obj nor pc2), which is missing or not a ccfr samples file: run again");
  if (count != n)
    throw Error("cannot resume: '" + p.string() + "' holds " + std::to_string(count) + " vertices, the run has " +
                std::to_string(n));
  std::map<int, std::vector<float>> by_frame;
  std::int32_t frame = 0;
  std::vector<float> s(3 * static_cast<size_t>(n));
  while (in.read(reinterpret_cast<char*>(&frame), sizeof frame) &&
         in.read(reinterpret_cast<char*>(s.data()), static_cast<std::streamsize>(s.size() * sizeof(float))))
    by_frame[frame] = s;  // a frame cut short by a kill is not whole and is left out
  std::vector<std::vector<float>> out;
  for (int f : frames) {
    const auto it = by_frame.find(f);
    if (it == by_frame.end())
      throw Error("cannot resume: '" + p.string() + "' has no sample of frame " + std::to_string(f) +
                  ", written before the checkpoint");
    out.push_back(it->second);
  }
  return out;
}

class UsdaSink final : public FrameSink {
 public:
  UsdaSink(const Topology& topo, double fps, bool keep_samples) : topo_(topo), fps_(fps), keep_(keep_samples) {}
  void write(const fs::path& dir, int frame, double, const Positions& x, const VertexFields&) override {
    frames_.push_back(frame);
    auto& s = samples_.emplace_back(3 * x.size());
    for (size_t v = 0; v < x.size(); ++v)
      for (int k = 0; k < 3; ++k) s[3 * v + k] = static_cast<float>(x[v][k]);
    if (!keep_) return;
    if (!started_) start_usda_samples(dir, static_cast<std::uint32_t>(x.size()));
    started_ = true;
    std::ofstream out(usda_samples_path(dir), std::ios::binary | std::ios::app);
    const std::int32_t f = frame;
    out.write(reinterpret_cast<const char*>(&f), sizeof f);
    out.write(reinterpret_cast<const char*>(s.data()), static_cast<std::streamsize>(s.size() * sizeof(float)));
    out.flush();
    if (!out) throw Error("cannot write '" + usda_samples_path(dir).string() + "'");
  }
  void resume(const fs::path& dir, const ResumedFrames& before) override {
    // The samples file is written again from the frames read back, as the uninterrupted run did.
    if (keep_) start_usda_samples(dir, static_cast<std::uint32_t>(topo_.num_vertices()));
    started_ = true;
    FrameSink::resume(dir, before);
  }
  void finish(const fs::path& dir) override {
    if (frames_.empty()) return;
    std::string s = "#usda 1.0\n(\n    defaultPrim = \"ccfr\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n";
    s += "    startTimeCode = " + std::to_string(frames_.front()) + "\n";
    s += "    endTimeCode = " + std::to_string(frames_.back()) + "\n";
    char fps[40];
    std::snprintf(fps, sizeof fps, "%.17g", fps_);
    s += std::string("    timeCodesPerSecond = ") + fps + "\n    framesPerSecond = " + fps + "\n)\n\n";
    s += "def Xform \"ccfr\"\n{\n";
    std::set<std::string> used;
    char buf[128];
    auto points = [&](const std::vector<float>& p, const ObjectInfo& o) {
      s += "[";
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
        const int n = std::snprintf(buf, sizeof buf, "%s(%.9g, %.9g, %.9g)", v == o.vertex_begin ? "" : ", ", p[3 * v],
                                    p[3 * v + 1], p[3 * v + 2]);
        s.append(buf, static_cast<size_t>(n));
      }
      s += "]";
    };
    auto ints = [&](const std::vector<Index>& a) {
      s += "[";
      for (size_t k = 0; k < a.size(); ++k) s += (k ? ", " : "") + std::to_string(a[k]);
      s += "]";
    };
    for (const ObjectInfo& o : topo_.objects) {
      const bool curves = o.polyline_end > o.polyline_begin, particles = o.kind == ObjectKind::particles;
      s += std::string("    def ") +
           (curves      ? "BasisCurves"
            : particles ? "Points"
                        : "Mesh") +
           " \"" + prim_name(o.name, used) + "\"\n    {\n";
      if (curves) {
        std::vector<Index> counts, idx;
        for (Index l = o.polyline_begin; l < o.polyline_end; ++l) {
          const auto row = topo_.polylines.row(l);
          counts.push_back(static_cast<Index>(row.size()));
        }
        s += "        uniform token type = \"linear\"\n        int[] curveVertexCounts = ";
        ints(counts);
        s += "\n";
      } else if (!particles) {
        std::vector<Index> counts(static_cast<size_t>(o.face_end - o.face_begin), 3), idx;
        for (Index f = o.face_begin; f < o.face_end; ++f)
          for (int k = 0; k < 3; ++k) idx.push_back(topo_.faces[f][k] - o.vertex_begin);
        s += "        int[] faceVertexCounts = ";
        ints(counts);
        s += "\n        int[] faceVertexIndices = ";
        ints(idx);
        s += "\n        uniform token subdivisionScheme = \"none\"\n";
      }
      s += "        custom string ccfr:name = \"" + escaped(o.name) + "\"\n";
      s += "        custom string ccfr:kind = \"" + std::string(to_string(o.kind)) + "\"\n";
      s += "        point3f[] points = ";
      points(samples_.front(), o);
      s += "\n        point3f[] points.timeSamples = {\n";
      for (size_t k = 0; k < frames_.size(); ++k) {
        s += "            " + std::to_string(frames_[k]) + ": ";
        points(samples_[k], o);
        s += ",\n";
      }
      s += "        }\n    }\n";
    }
    s += "}\n";
    make_dir(dir / "usd");
    write_file_atomic(dir / "usd" / "scene.usda", s);
  }

 private:
  static std::string escaped(const std::string& in) {
    std::string o;
    for (char c : in) o += c == '"' || c == '\\' ? std::string("\\") + c : std::string(1, c);
    return o;
  }
  const Topology& topo_;
  double fps_;
  bool keep_ = false;     ///< keep the samples file (usda_keeps_samples)
  bool started_ = false;  ///< the samples file was started by this sink
  std::vector<int> frames_;
  std::vector<std::vector<float>> samples_;
};

}  // namespace

void FrameSink::resume(const fs::path& dir, const ResumedFrames& before) {
  if (before.frames.empty()) return;
  if (!before.positions)
    throw Error("cannot resume '" + dir.string() +
                "': its whole-run files (usda) are rebuilt from the frames written before the checkpoint, and "
                "output.formats has neither obj nor pc2 to read them from: run again");
  replay_frames({this}, dir, before.frames, before.positions, before.fps, false);
}

void replay_frames(const std::vector<FrameSink*>& sinks, const fs::path& dir, const std::vector<int>& frames,
                   const FramePositions& positions, double fps, bool velocities) {
  Positions prev;
  int prev_frame = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const int frame = frames[k];
    Positions x = positions(k, frame);
    VertexFields fields;
    if (velocities) {
      fields.velocity.assign(x.size(), Vec3::Zero());
      if (!prev.empty() && frame > prev_frame)
        for (size_t v = 0; v < x.size(); ++v) fields.velocity[v] = (x[v] - prev[v]) * fps / (frame - prev_frame);
    }
    for (FrameSink* s : sinks) s->write(dir, frame, fps > 0 ? frame / fps : 0.0, x, fields);
    prev_frame = frame;
    prev = std::move(x);
  }
}

void resume_frame_sinks(const std::vector<FrameSink*>& sinks, const fs::path& dir, const Topology& topo,
                        const std::vector<OutputFormat>& formats, int last, const std::vector<int>& frames,
                        double fps) {
  ResumedFrames before{last, frames, {}, fps};
  auto has = [&](OutputFormat f) { return std::find(formats.begin(), formats.end(), f) != formats.end(); };
  // Read before any sink changes a file: a USDA layer alone is rebuilt from its samples file.
  if (usda_keeps_samples(formats) && !frames.empty()) {
    auto samples = std::make_shared<std::vector<std::vector<float>>>(
        read_usda_samples(dir, frames, static_cast<std::uint32_t>(topo.num_vertices())));
    before.positions = [samples](size_t k, int) {
      const std::vector<float>& s = (*samples)[k];
      Positions x(s.size() / 3);
      for (size_t v = 0; v < x.size(); ++v) x[v] = Vec3(s[3 * v], s[3 * v + 1], s[3 * v + 2]);
      return x;
    };
  }
  // OBJ frames hold the exact positions; PC2 holds them as float, which is all USDA writes.
  if (has(OutputFormat::obj)) {
    before.positions = [dir, &topo](size_t, int frame) {
      const fs::path p = dir / "frames" / frame_name(frame, "obj");
      Frame fr = read_frame_obj(p);
      if (static_cast<Index>(fr.v.size()) != topo.num_vertices())
        throw Error("cannot resume: '" + p.string() + "' has " + std::to_string(fr.v.size()) +
                    " vertices, the run has " + std::to_string(topo.num_vertices()));
      return std::move(fr.v);
    };
  } else if (has(OutputFormat::pc2)) {
    before.positions = [dir, &topo](size_t k, int) { return read_pc2_sample(dir / "blender", topo, k); };
  }
  // Whatever can refuse the resume runs before any file changes: the per-frame files are checked
  // here, the USDA layer only reads (it is written at the end), the PC2 caches check themselves
  // before they are cut; the frames after the checkpoint are removed last.
  std::vector<std::pair<int, FrameSink*>> order;
  size_t k = 0;
  for (OutputFormat f : formats) {
    if (f == OutputFormat::obj || k >= sinks.size()) continue;
    if (f == OutputFormat::ply) check_frames_before(dir / "frames", "ply", before);
    if (f == OutputFormat::vtu) check_frames_before(dir / "vtk", "vtu", before);
    order.emplace_back(f == OutputFormat::usda ? 0 : f == OutputFormat::pc2 ? 1 : 2, sinks[k++]);
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [rank, s] : order) s->resume(dir, before);
}

bool usda_keeps_samples(const std::vector<OutputFormat>& formats) {
  auto has = [&](OutputFormat f) { return std::find(formats.begin(), formats.end(), f) != formats.end(); };
  return has(OutputFormat::usda) && !has(OutputFormat::obj) && !has(OutputFormat::pc2);
}

std::unique_ptr<FrameSink> make_frame_sink(OutputFormat format, const Topology& topo, double fps, int every,
                                           const std::vector<OutputFormat>& formats) {
  switch (format) {
    case OutputFormat::ply:
      return std::make_unique<PlySink>(topo);
    case OutputFormat::vtu:
      return std::make_unique<VtuSink>(topo);
    case OutputFormat::pc2:
      return std::make_unique<Pc2Sink>(topo, fps, every);
    case OutputFormat::usda:
      return std::make_unique<UsdaSink>(topo, fps, usda_keeps_samples(formats));
    case OutputFormat::obj:
      break;
  }
  throw Error("make_frame_sink: the OBJ frames are written by RunWriter");
}

Positions read_ply_positions(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open '" + path.string() + "'");
  std::string line;
  long nv = -1;
  bool binary = false;
  while (std::getline(in, line) && line != "end_header") {
    if (line.rfind("element vertex ", 0) == 0) nv = std::stol(line.substr(15));
    if (line == "format binary_little_endian 1.0") binary = true;
  }
  if (nv < 0 || !binary) throw Error(path.string() + ": not a binary little-endian PLY with a vertex element");
  Positions x(static_cast<size_t>(nv));
  for (auto& p : x) {
    float c[3];
    if (!in.read(reinterpret_cast<char*>(c), sizeof c)) throw Error(path.string() + ": truncated vertex data");
    p = Vec3(c[0], c[1], c[2]);
  }
  return x;
}

}  // namespace ccfr::io
