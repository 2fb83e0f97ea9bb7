#pragma once
/// @file renderer.hpp
/// Ray-cast pictures of one frame with Embree: triangles (two-sided, smooth-shaded), strands as
/// round tubes, particles as spheres; a key light with hard shadows and ambient occlusion.
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "ccfr/io/obj.hpp"
#include "ccfr/render/camera.hpp"
#include "ccfr/render/image.hpp"

namespace ccfr::render {

/// What the user chooses. Zero radii mean "choose from the scene" (see resolve_view()).
struct RenderOptions {
  int width = 800;
  int height = 600;
  int samples = 4;             ///< camera rays per pixel, on a stratified grid (rounded down to a square, >= 1)
  int ao_samples = 4;          ///< ambient-occlusion rays per camera ray (0 disables occlusion)
  bool shadows = true;         ///< hard shadows from the key light
  bool ground = true;          ///< a checkered floor just below the scene, catching shadows
  double strand_radius = 0.0;  ///< tube radius of strands; 0 = automatic
  double point_radius = 0.0;   ///< sphere radius of particles; 0 = automatic
  /// Contact offset ξ of the run (run.json), if known: strands and particles then get radius
  /// ξ/2, their physical thickness, so touching spheres look touching.
  double offset_hint = 0.0;
  Vec3 up = Vec3::UnitY();
  double fov_deg = 40.0;
};

/// Everything that must stay fixed over the frames of one run so that a video does not flicker:
/// camera, radii, floor and occlusion distance.
struct View {
  Camera camera;
  double strand_radius = 0.0;
  double point_radius = 0.0;
  bool ground = true;
  double ground_height = 0.0;      ///< floor position along `camera.up`
  double ground_cell = 0.1;        ///< checker size
  double ground_fade = 1.0;        ///< distance from the target over which the floor fades out
  double ao_distance = 0.1;        ///< how far occluders darken a point
  double epsilon = 1e-6;           ///< ray offset off surfaces
  Vec3 light_dir = Vec3::UnitY();  ///< towards the key light, unit
};

/// Builds the View for a run: `bounds` covers every frame to draw, `sample` is one of them
/// (radii are measured on it). `camera` overrides the fitted camera.
View resolve_view(const Bounds& bounds, const io::Frame& sample, const RenderOptions& options,
                  const std::optional<Camera>& camera = std::nullopt);

/// Median length of triangle edges and polyline segments of a frame (0 if it has none).
double median_edge_length(const io::Frame& frame);

/// One rendered frame.
struct RenderResult {
  Image image;
  /// #pixels, row-major: the frame object seen in each pixel (majority over its samples),
  /// -1 for background, -2 for the floor.
  std::vector<std::int32_t> object_id;
  /// Pixel count per frame object (same order as Frame::objects).
  std::vector<std::int64_t> coverage;
};

/// Object colour (linear RGB, 0..1) of the `index`-th object of a frame: a fixed qualitative palette.
std::array<double, 3> object_color(std::size_t index);

/// Ray caster owning one Embree device; render() may be called repeatedly (not concurrently).
/// Pixels are shaded in parallel with oneTBB (ccfr::parallel_for, honours ccfr::set_thread_count).
/// The result is deterministic: sample positions depend on the pixel only.
class Renderer {
 public:
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  RenderResult render(const io::Frame& frame, const View& view, const RenderOptions& options);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ccfr::render
