#include "ccfr/render/renderer.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::render {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Integer hash (PCG output permutation): decorrelates per-pixel sample sequences so the
/// picture does not depend on the order in which threads visit pixels.
std::uint32_t hash32(std::uint32_t x) {
  x = x * 747796405u + 2891336453u;
  const std::uint32_t w = ((x >> ((x >> 28u) + 4u)) ^ x) * 277803737u;
  return (w >> 22u) ^ w;
}
double unit_float(std::uint32_t h) { return (h >> 8) * (1.0 / 16777216.0); }

double srgb_encode(double c) {
  c = std::clamp(c, 0.0, 1.0);
  return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}
double srgb_decode(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

enum class PrimKind : std::uint8_t { triangles, curves, spheres, ground };

/// What an Embree geometry id stands for.
struct GeomInfo {
  std::int32_t object = -1;
  PrimKind kind = PrimKind::triangles;
  std::int32_t face_begin = 0;  ///< first frame face of this geometry (triangles)
};

/// Median of `values` (0 for none); reorders them.
double median(std::vector<double>& values) {
  if (values.empty()) return 0.0;
  auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

/// Median nearest-neighbour distance of the frame's free points, measured on at most 256 of
/// them against all (exact for the sample, O(256 n)).
double median_point_spacing(const io::Frame& frame) {
  const auto& pts = frame.points;
  if (pts.size() < 2) return 0.0;
  const size_t stride = std::max<size_t>(1, pts.size() / 256);
  std::vector<double> nearest;
  for (size_t i = 0; i < pts.size(); i += stride) {
    double best = std::numeric_limits<double>::infinity();
    const Vec3& p = frame.v[static_cast<size_t>(pts[i])];
    for (size_t j = 0; j < pts.size(); ++j) {
      if (j == i) continue;
      const double d = (frame.v[static_cast<size_t>(pts[j])] - p).squaredNorm();
      if (d > 0) best = std::min(best, d);
    }
    if (std::isfinite(best)) nearest.push_back(std::sqrt(best));
  }
  return median(nearest);
}

void embree_error(void* /*user*/, RTCError code, const char* message) {
  log::error("embree error {}: {}", static_cast<int>(code), message ? message : "");
}

}  // namespace

std::array<double, 3> object_color(std::size_t index) {
  // A qualitative palette (sRGB), distinct under the key light and readable when shaded.
  static constexpr std::array<std::array<int, 3>, 10> palette = {{{66, 133, 204},
                                                                  {230, 126, 34},
                                                                  {76, 175, 80},
                                                                  {214, 64, 69},
                                                                  {149, 103, 189},
                                                                  {0, 170, 170},
                                                                  {230, 190, 40},
                                                                  {227, 119, 194},
                                                                  {140, 100, 75},
                                                                  {120, 130, 140}}};
  const auto& c = palette[index % palette.size()];
  return {srgb_decode(c[0] / 255.0), srgb_decode(c[1] / 255.0), srgb_decode(c[2] / 255.0)};
}

double median_edge_length(const io::Frame& frame) {
  std::vector<double> lengths;
  // A few thousand edges pin the median down; sample evenly on big meshes.
  const size_t fstride = std::max<size_t>(1, frame.faces.size() / 4096);
  for (size_t f = 0; f < frame.faces.size(); f += fstride) {
    const Vec3i& t = frame.faces[f];
    for (int k = 0; k < 3; ++k)
      lengths.push_back((frame.v[static_cast<size_t>(t[k])] - frame.v[static_cast<size_t>(t[(k + 1) % 3])]).norm());
  }
  for (const auto& line : frame.lines)
    for (size_t k = 0; k + 1 < line.size(); ++k)
      lengths.push_back((frame.v[static_cast<size_t>(line[k])] - frame.v[static_cast<size_t>(line[k + 1])]).norm());
  return median(lengths);
}

View resolve_view(const Bounds& bounds, const io::Frame& sample, const RenderOptions& options,
                  const std::optional<Camera>& camera) {
  View view;
  const double aspect = static_cast<double>(std::max(options.width, 1)) / std::max(options.height, 1);
  view.camera = camera ? *camera : fit_camera(bounds, aspect, options.up, options.fov_deg);
  view.camera.up = options.up.normalized();
  const double diag = bounds.empty() ? 1.0 : std::max(bounds.diagonal(), 1e-9);
  const double dist =
      bounds.empty() ? (view.camera.eye - view.camera.target).norm() : (bounds.center() - view.camera.eye).norm();
  const double pixel = pixel_size_at(view.camera, std::max(options.height, 1), dist);

  // Strands: the physical thickness ξ/2 when known, else a fraction of a segment; never thinner
  // than about a pixel, or they vanish between samples.
  view.strand_radius = options.strand_radius;
  if (view.strand_radius <= 0) {
    std::vector<double> seg;
    for (const auto& line : sample.lines)
      for (size_t k = 0; k + 1 < line.size(); ++k)
        seg.push_back((sample.v[static_cast<size_t>(line[k])] - sample.v[static_cast<size_t>(line[k + 1])]).norm());
    const double m = median(seg);
    view.strand_radius = options.offset_hint > 0 ? 0.5 * options.offset_hint : (m > 0 ? 0.15 * m : 2e-3 * diag);
    view.strand_radius = std::max(view.strand_radius, 0.6 * pixel);
  }
  view.point_radius = options.point_radius;
  if (view.point_radius <= 0) {
    const double s = median_point_spacing(sample);
    view.point_radius = options.offset_hint > 0 ? 0.5 * options.offset_hint : (s > 0 ? 0.45 * s : 5e-3 * diag);
    view.point_radius = std::max(view.point_radius, 0.8 * pixel);
  }

  view.ground = options.ground && !bounds.empty();
  const Vec3 up = view.camera.up;
  view.ground_height = 0.0;
  if (!bounds.empty()) {
    // The lowest corner along `up` (works for signed axes and arbitrary up vectors).
    double lowest = std::numeric_limits<double>::infinity();
    for (int c = 0; c < 8; ++c) {
      const Vec3 corner((c & 1) ? bounds.hi.x() : bounds.lo.x(), (c & 2) ? bounds.hi.y() : bounds.lo.y(),
                        (c & 4) ? bounds.hi.z() : bounds.lo.z());
      lowest = std::min(lowest, corner.dot(up));
    }
    view.ground_height = lowest - 2e-3 * diag - view.point_radius;
  }
  view.ground_cell = std::pow(10.0, std::floor(std::log10(diag / 3.0)));
  view.ground_fade = 2.5 * diag;
  view.ao_distance = 0.06 * diag;
  view.epsilon = 2e-6 * diag;

  Vec3 r, u, f;
  view.camera.basis(r, u, f);
  // Key light above, slightly behind the viewer's left shoulder: folds get a lit and a shaded
  // side, and shadows fall onto the floor below the objects.
  const Vec3 back = (-f - (-f).dot(up) * up);
  view.light_dir = (1.0 * up + 0.45 * (back.norm() > 1e-9 ? back.normalized() : Vec3::Zero()) - 0.35 * r).normalized();
  return view;
}

struct Renderer::Impl {
  RTCDevice device = nullptr;

  Impl() {
    device = rtcNewDevice("verbose=0");
    if (device == nullptr)
      throw Error("cannot create an Embree device (error " + std::to_string(rtcGetDeviceError(nullptr)) + ")");
    rtcSetDeviceErrorFunction(device, embree_error, nullptr);
  }
  ~Impl() { rtcReleaseDevice(device); }
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {}
Renderer::~Renderer() = default;

namespace {

/// An Embree scene for one frame, with the per-vertex normals the shader interpolates.
class FrameScene {
 public:
  FrameScene(RTCDevice device, const io::Frame& frame, const View& view) : frame_(frame) {
    scene_ = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_MEDIUM);
    const size_t nv = frame.v.size();
    // One shared float3 vertex array for every triangle geometry; Embree reads 16 bytes at a
    // time, hence one float of padding.
    positions_.resize(nv * 3 + 1, 0.0f);
    for (size_t i = 0; i < nv; ++i)
      for (int c = 0; c < 3; ++c) positions_[i * 3 + c] = static_cast<float>(frame.v[i][c]);
    compute_normals();

    for (size_t o = 0; o < frame.objects.size(); ++o) {
      const io::FrameObject& obj = frame.objects[o];
      if (obj.face_end > obj.face_begin) add_triangles(device, static_cast<std::int32_t>(o), obj);
      if (obj.line_end > obj.line_begin) add_curves(device, static_cast<std::int32_t>(o), obj, view.strand_radius);
      if (obj.point_end > obj.point_begin) add_spheres(device, static_cast<std::int32_t>(o), obj, view.point_radius);
    }
    if (view.ground) add_ground(device, view);
    rtcCommitScene(scene_);
  }
  ~FrameScene() { rtcReleaseScene(scene_); }
  FrameScene(const FrameScene&) = delete;
  FrameScene& operator=(const FrameScene&) = delete;

  RTCScene scene() const { return scene_; }
  const GeomInfo& info(unsigned geom_id) const { return geoms_[geom_id]; }
  const std::vector<Vec3>& normals() const { return normals_; }

 private:
  void compute_normals() {
    normals_.assign(frame_.v.size(), Vec3::Zero());
    for (const Vec3i& t : frame_.faces) {
      // Area-weighted: the unnormalised cross product.
      const Vec3 n = (frame_.v[static_cast<size_t>(t[1])] - frame_.v[static_cast<size_t>(t[0])])
                         .cross(frame_.v[static_cast<size_t>(t[2])] - frame_.v[static_cast<size_t>(t[0])]);
      for (int k = 0; k < 3; ++k) normals_[static_cast<size_t>(t[k])] += n;
    }
    for (Vec3& n : normals_) {
      const double len = n.norm();
      if (len > 0) n /= len;
    }
  }

  unsigned attach(RTCGeometry g, GeomInfo info) {
    rtcCommitGeometry(g);
    const unsigned id = rtcAttachGeometry(scene_, g);
    rtcReleaseGeometry(g);
    if (geoms_.size() <= id) geoms_.resize(id + 1);
    geoms_[id] = info;
    return id;
  }

  void add_triangles(RTCDevice device, std::int32_t object, const io::FrameObject& obj) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, positions_.data(), 0, 3 * sizeof(float),
                               frame_.v.size());
    const size_t nf = static_cast<size_t>(obj.face_end - obj.face_begin);
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), nf));
    for (size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k)
        idx[f * 3 + k] = static_cast<unsigned>(frame_.faces[static_cast<size_t>(obj.face_begin) + f][k]);
    attach(g, {object, PrimKind::triangles, obj.face_begin});
  }

  void add_curves(RTCDevice device, std::int32_t object, const io::FrameObject& obj, double radius) {
    // Round linear curves index the first vertex of each segment; a polyline's vertices must
    // therefore be consecutive in the curve's own vertex buffer.
    size_t nverts = 0, nsegs = 0;
    for (Index l = obj.line_begin; l < obj.line_end; ++l) {
      nverts += frame_.lines[static_cast<size_t>(l)].size();
      nsegs += frame_.lines[static_cast<size_t>(l)].size() - 1;
    }
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
    auto* vb = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), nverts));
    auto* ib = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(unsigned), nsegs));
    size_t v = 0, s = 0;
    for (Index l = obj.line_begin; l < obj.line_end; ++l) {
      const auto& line = frame_.lines[static_cast<size_t>(l)];
      for (size_t k = 0; k < line.size(); ++k, ++v) {
        const Vec3& p = frame_.v[static_cast<size_t>(line[k])];
        vb[v * 4 + 0] = static_cast<float>(p.x());
        vb[v * 4 + 1] = static_cast<float>(p.y());
        vb[v * 4 + 2] = static_cast<float>(p.z());
        vb[v * 4 + 3] = static_cast<float>(radius);
        if (k + 1 < line.size()) ib[s++] = static_cast<unsigned>(v);
      }
    }
    attach(g, {object, PrimKind::curves, 0});
  }

  void add_spheres(RTCDevice device, std::int32_t object, const io::FrameObject& obj, double radius) {
    const size_t n = static_cast<size_t>(obj.point_end - obj.point_begin);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    auto* vb = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), n));
    for (size_t i = 0; i < n; ++i) {
      const Vec3& p = frame_.v[static_cast<size_t>(frame_.points[static_cast<size_t>(obj.point_begin) + i])];
      vb[i * 4 + 0] = static_cast<float>(p.x());
      vb[i * 4 + 1] = static_cast<float>(p.y());
      vb[i * 4 + 2] = static_cast<float>(p.z());
      vb[i * 4 + 3] = static_cast<float>(radius);
    }
    attach(g, {object, PrimKind::spheres, 0});
  }

  void add_ground(RTCDevice device, const View& view) {
    const Vec3 up = view.camera.up.normalized();
    Vec3 a = up.cross(std::abs(up.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).normalized();
    Vec3 b = up.cross(a);
    // Large enough that its edge stays out of a fitted view, small enough for float precision.
    const double half = 50.0 * std::max((view.camera.eye - view.camera.target).norm(), 1e-6);
    const Vec3 c = view.camera.target - (view.camera.target.dot(up) - view.ground_height) * up;
    const Vec3 corners[4] = {c - half * a - half * b, c + half * a - half * b, c + half * a + half * b,
                             c - half * a + half * b};
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4));
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) vb[i * 3 + k] = static_cast<float>(corners[i][k]);
    auto* ib = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2));
    const unsigned tris[6] = {0, 1, 2, 0, 2, 3};
    std::copy(tris, tris + 6, ib);
    attach(g, {-2, PrimKind::ground, 0});
  }

  const io::Frame& frame_;
  RTCScene scene_ = nullptr;
  std::vector<float> positions_;
  std::vector<Vec3> normals_;
  std::vector<GeomInfo> geoms_;
};

/// Shading of one camera sample.
struct Sample {
  Vec3 color = Vec3::Zero();  ///< linear RGB
  std::int32_t object = -1;
};

class Shader {
 public:
  Shader(const FrameScene& scene, const io::Frame& frame, const View& view, const RenderOptions& options)
      : scene_(scene), frame_(frame), view_(view), options_(options) {
    view.camera.basis(right_, up_, forward_);
    tan_half_ = std::tan(0.5 * view.camera.fov_deg * kPi / 180.0);
    aspect_ = static_cast<double>(options.width) / options.height;
    for (size_t o = 0; o < frame.objects.size(); ++o) {
      const auto c = object_color(o);
      colors_.emplace_back(c[0], c[1], c[2]);
    }
    world_up_ = view.camera.up.normalized();
    rtcInitIntersectContext(&context_);
  }

  /// Shades the camera ray through image point (px, py) (pixels, y down). `seed` drives the
  /// occlusion directions.
  Sample shade(double px, double py, std::uint32_t seed) const {
    const double sx = (2.0 * px / options_.width - 1.0) * tan_half_ * aspect_;
    const double sy = (1.0 - 2.0 * py / options_.height) * tan_half_;
    const Vec3 dir = (forward_ + sx * right_ + sy * up_).normalized();
    const Vec3& org = view_.camera.eye;

    RTCRayHit rh;
    set_ray(rh.ray, org, dir, 0.0f, std::numeric_limits<float>::infinity());
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    RTCIntersectContext ctx = context_;
    rtcIntersect1(scene_.scene(), &ctx, &rh);

    Sample out;
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
      out.color = background(py);
      return out;
    }
    const GeomInfo& gi = scene_.info(rh.hit.geomID);
    out.object = gi.object;
    const Vec3 p = org + static_cast<double>(rh.ray.tfar) * dir;

    Vec3 ng(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
    Vec3 n = Vec3::Zero();
    Vec3 base = Vec3::Zero();
    bool back = false;
    if (gi.kind == PrimKind::triangles) {
      const Vec3i& t = frame_.faces[static_cast<size_t>(gi.face_begin) + rh.hit.primID];
      const Vec3& a = frame_.v[static_cast<size_t>(t[0])];
      ng = (frame_.v[static_cast<size_t>(t[1])] - a).cross(frame_.v[static_cast<size_t>(t[2])] - a);
      const double u = rh.hit.u, v = rh.hit.v;
      const auto& vn = scene_.normals();
      n = (1.0 - u - v) * vn[static_cast<size_t>(t[0])] + u * vn[static_cast<size_t>(t[1])] +
          v * vn[static_cast<size_t>(t[2])];
      base = colors_[static_cast<size_t>(gi.object)];
    } else if (gi.kind == PrimKind::ground) {
      const Vec3 q = p - view_.camera.target;
      Vec3 a = world_up_.cross(std::abs(world_up_.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).normalized();
      const Vec3 b = world_up_.cross(a);
      const long ia = static_cast<long>(std::floor(q.dot(a) / view_.ground_cell));
      const long ib = static_cast<long>(std::floor(q.dot(b) / view_.ground_cell));
      base = ((ia + ib) & 1) ? Vec3::Constant(0.56) : Vec3::Constant(0.64);
      ng = world_up_;
      n = world_up_;
    } else {
      base = colors_[static_cast<size_t>(gi.object)];
    }
    if (ng.squaredNorm() <= 0 || !std::isfinite(ng.squaredNorm())) ng = -dir;
    ng.normalize();
    if (gi.kind != PrimKind::triangles) n = ng;
    // Two-sided surfaces: face the viewer. The back of a cloth gets a darker, greyer tint so the
    // two sides of a fold read apart.
    if (ng.dot(dir) > 0) {
      ng = -ng;
      n = -n;
      back = true;
    }
    if (n.squaredNorm() <= 1e-12 || n.dot(ng) < 0.05) n = ng;
    n.normalize();
    if (back && gi.kind == PrimKind::triangles) base = 0.55 * base + 0.12 * Vec3::Constant(base.mean());

    const Vec3 o = p + view_.epsilon * ng;
    double direct = std::max(0.0, n.dot(view_.light_dir));
    if (direct > 0 && ng.dot(view_.light_dir) <= 0) direct = 0;  // light behind the true surface
    if (direct > 0 && options_.shadows && occluded(o, view_.light_dir, std::numeric_limits<float>::infinity()))
      direct = 0;

    // Ambient occlusion: cosine-weighted rays around the true normal, stratified per sample.
    double ao = 1.0;
    const int na = options_.ao_samples;
    if (na > 0) {
      Vec3 t1 = ng.cross(std::abs(ng.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).normalized();
      const Vec3 t2 = ng.cross(t1);
      const double r1 = unit_float(hash32(seed ^ 0x9e3779b9u));
      const double r2 = unit_float(hash32(seed ^ 0x85ebca6bu));
      int open = 0;
      for (int k = 0; k < na; ++k) {
        // Cranley-Patterson rotated Fibonacci lattice: even coverage with few rays.
        const double e1 = std::fmod((k + 0.5) / na + r1, 1.0);
        const double e2 = std::fmod(k * 0.6180339887498949 + r2, 1.0);
        const double rad = std::sqrt(e1), phi = 2.0 * kPi * e2;
        const Vec3 d = (rad * std::cos(phi) * t1 + rad * std::sin(phi) * t2 + std::sqrt(1.0 - e1) * ng).normalized();
        if (!occluded(o, d, static_cast<float>(view_.ao_distance))) ++open;
      }
      ao = static_cast<double>(open) / na;
    }
    // Sky light brighter from above, so upward faces read lighter than overhangs.
    const double sky = 0.75 + 0.25 * n.dot(world_up_);
    out.color = base.cwiseProduct(Vec3::Constant(0.42 * ao * sky + 0.78 * direct));
    if (gi.kind == PrimKind::ground) {
      // Fade the floor into the background with distance: a hint of where down is, without a
      // busy checker pattern at the horizon.
      const double far = (p - view_.camera.target).norm() / std::max(view_.ground_fade, 1e-12);
      const double fade = 1.0 - std::exp(-far * far);
      out.color = (1.0 - fade) * out.color + fade * background(py);
    }
    return out;
  }

 private:
  static void set_ray(RTCRay& ray, const Vec3& org, const Vec3& dir, float tnear, float tfar) {
    ray.org_x = static_cast<float>(org.x());
    ray.org_y = static_cast<float>(org.y());
    ray.org_z = static_cast<float>(org.z());
    ray.dir_x = static_cast<float>(dir.x());
    ray.dir_y = static_cast<float>(dir.y());
    ray.dir_z = static_cast<float>(dir.z());
    ray.tnear = tnear;
    ray.tfar = tfar;
    ray.time = 0.0f;
    ray.mask = 0xFFFFFFFFu;
    ray.id = 0;
    ray.flags = 0;
  }

  bool occluded(const Vec3& org, const Vec3& dir, float tfar) const {
    RTCRay ray;
    set_ray(ray, org, dir, static_cast<float>(view_.epsilon), tfar);
    RTCIntersectContext ctx = context_;
    rtcOccluded1(scene_.scene(), &ctx, &ray);
    return ray.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
  }

  Vec3 background(double py) const {
    const double t = std::clamp(py / options_.height, 0.0, 1.0);
    return (1.0 - t) * Vec3(0.62, 0.70, 0.80) + t * Vec3(0.92, 0.93, 0.95);
  }

  const FrameScene& scene_;
  const io::Frame& frame_;
  const View& view_;
  const RenderOptions& options_;
  Vec3 right_, up_, forward_, world_up_;
  double tan_half_ = 0.0, aspect_ = 1.0;
  std::vector<Vec3> colors_;
  RTCIntersectContext context_;
};

}  // namespace

RenderResult Renderer::render(const io::Frame& frame, const View& view, const RenderOptions& options) {
  if (options.width <= 0 || options.height <= 0)
    throw Error("image size must be positive, got " + std::to_string(options.width) + "x" +
                std::to_string(options.height));
  for (size_t o = 0; o < frame.objects.size(); ++o) {
    const auto& obj = frame.objects[o];
    for (Index f = obj.face_begin; f < obj.face_end; ++f)
      for (int k = 0; k < 3; ++k)
        if (frame.faces[static_cast<size_t>(f)][k] < 0 ||
            static_cast<size_t>(frame.faces[static_cast<size_t>(f)][k]) >= frame.v.size())
          throw Error("face " + std::to_string(f) + " of object '" + obj.name + "' indexes a missing vertex");
  }
  // Embree asserts on rays and boxes that are not finite in float: refuse such a frame with the
  // vertex named instead (frames read from disk are already checked by read_frame_obj).
  for (size_t i = 0; i < frame.v.size(); ++i)
    if (!(frame.v[i].cwiseAbs().maxCoeff() <= kMaxCoordinate)) {
      std::string object;
      for (const auto& o : frame.objects)
        if (static_cast<Index>(i) >= o.vertex_begin && static_cast<Index>(i) < o.vertex_end) object = o.name;
      throw Error(
          "vertex " + std::to_string(i + 1) + (object.empty() ? "" : " (object '" + object + "')") +
          " has a coordinate that is not finite or beyond +-1e6, ccfr's bound on coordinates: cannot render it");
    }
  const FrameScene scene(impl_->device, frame, view);
  const Shader shader(scene, frame, view, options);

  const int w = options.width, h = options.height;
  const int grid = std::clamp(static_cast<int>(std::floor(std::sqrt(std::max(options.samples, 1)))), 1, 8);
  const int spp = grid * grid;

  RenderResult result;
  result.image = Image(w, h);
  result.object_id.assign(static_cast<size_t>(w) * h, -1);
  ccfr::parallel_for(
      h,
      [&](Index y0, Index y1) {
        std::vector<std::int32_t> ids(static_cast<size_t>(spp));
        for (Index y = y0; y < y1; ++y)
          for (int x = 0; x < w; ++x) {
            const std::uint32_t pixel_seed =
                hash32(static_cast<std::uint32_t>(y) * 0x9E3779B1u + static_cast<std::uint32_t>(x));
            Vec3 acc = Vec3::Zero();
            for (int s = 0; s < spp; ++s) {
              const std::uint32_t seed = hash32(pixel_seed + static_cast<std::uint32_t>(s) * 0x632BE5ABu);
              // Stratified jitter inside sub-pixel cell (s % grid, s / grid); the centre when spp == 1.
              const double jx = spp == 1 ? 0.5 : (s % grid + unit_float(hash32(seed ^ 0x1234567u))) / grid;
              const double jy = spp == 1 ? 0.5 : (s / grid + unit_float(hash32(seed ^ 0x7654321u))) / grid;
              const Sample smp = shader.shade(x + jx, y + jy, seed);
              acc += smp.color;
              ids[static_cast<size_t>(s)] = smp.object;
            }
            acc /= spp;
            std::uint8_t* px = result.image.pixel(x, static_cast<int>(y));
            for (int c = 0; c < 3; ++c) px[c] = static_cast<std::uint8_t>(std::lround(255.0 * srgb_encode(acc[c])));
            // Majority vote (ties: the smallest id) so coverage counts are not biased by ties.
            std::sort(ids.begin(), ids.end());
            std::int32_t best = ids[0];
            int best_count = 0;
            for (size_t i = 0; i < ids.size();) {
              size_t j = i;
              while (j < ids.size() && ids[j] == ids[i]) ++j;
              if (static_cast<int>(j - i) > best_count) {
                best_count = static_cast<int>(j - i);
                best = ids[i];
              }
              i = j;
            }
            result.object_id[static_cast<size_t>(y) * w + x] = best;
          }
      },
      4);
  result.coverage.assign(frame.objects.size(), 0);
  for (const std::int32_t id : result.object_id)
    if (id >= 0 && static_cast<size_t>(id) < result.coverage.size()) ++result.coverage[static_cast<size_t>(id)];
  return result;
}

}  // namespace ccfr::render
