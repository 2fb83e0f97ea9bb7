// `vtu`: vtk/frame_N.vtu (VTK XML UnstructuredGrid with the per-vertex fields) and the collection
// vtk/frames.pvd, for ParaView.
#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "../builtin_frame_writers.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

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

// VTK XML UnstructuredGrid, zlib-compressed binary appended data (UInt64 headers), and a PVD collection.
class VtuSink final : public FrameSink {
 public:
  explicit VtuSink(const Topology& topo) : cells_(make_cells(topo)) {
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
  void check_resume(const fs::path& dir, const ResumedFrames& before) override {
    check_frames_before(dir / "vtk", "vtu", before);
  }
  bool wants_fields() const override { return true; }

 private:
  void add_entry(int frame, double time) {
    char t[40];
    std::snprintf(t, sizeof t, "%.17g", time);
    entries_ +=
        std::string("    <DataSet timestep=\"") + t + "\" part=\"0\" file=\"" + frame_name(frame, "vtu") + "\"/>\n";
  }
  Cells cells_;
  std::vector<std::int32_t> object_;
  std::string entries_;
};

}  // namespace

void register_frame_writer_vtu(FrameWriterRegistry& registry) {
  registry.add({"vtu",
                "vtk/frame_N.vtu + vtk/frames.pvd with per-vertex fields (ParaView)",
                {},
                [](const ParamValues&, const FrameSinkContext& ctx) { return std::make_unique<VtuSink>(ctx.topo); }});
}

}  // namespace ccfr::io
