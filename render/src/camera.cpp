#include "ccfr/render/camera.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"

namespace ccfr::render {

namespace {
constexpr double kPi = 3.14159265358979323846;
double tan_half(double fov_deg) { return std::tan(0.5 * fov_deg * kPi / 180.0); }
}  // namespace

Bounds frame_bounds(const io::Frame& frame) {
  Bounds b;
  for (const Vec3& p : frame.v) b.extend(p);
  return b;
}

void Camera::basis(Vec3& right, Vec3& true_up, Vec3& forward) const {
  forward = (target - eye).normalized();
  Vec3 u = up.normalized();
  // Looking along the up axis leaves the roll undefined: borrow another axis.
  if (std::abs(forward.dot(u)) > 0.999) u = std::abs(forward.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitZ();
  right = forward.cross(u).normalized();
  true_up = right.cross(forward);
}

Camera parse_camera(std::string_view text, const Vec3& up) {
  std::vector<double> values;
  std::string_view rest = text;
  while (true) {
    const size_t comma = rest.find(',');
    std::string token(rest.substr(0, comma));
    token.erase(0, token.find_first_not_of(" \t"));
    token.erase(token.find_last_not_of(" \t") + 1);
    double value = 0;
    const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (token.empty() || ec != std::errc() || ptr != token.data() + token.size() || !std::isfinite(value))
      throw Error("--camera: '" + token +
                  "' is not a number (expected eye_x,eye_y,eye_z,target_x,target_y,target_z,fov_deg)");
    values.push_back(value);
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  if (values.size() != 7)
    throw Error(
        "--camera: expected 7 comma-separated numbers eye_x,eye_y,eye_z,target_x,target_y,target_z,fov_deg, got " +
        std::to_string(values.size()));
  Camera cam;
  cam.eye = Vec3(values[0], values[1], values[2]);
  cam.target = Vec3(values[3], values[4], values[5]);
  cam.fov_deg = values[6];
  cam.up = up;
  if ((cam.eye - cam.target).norm() <= 0) throw Error("--camera: eye and target coincide");
  if (!(cam.fov_deg > 0 && cam.fov_deg < 180)) throw Error("--camera: fov_deg must lie in (0, 180)");
  return cam;
}

Vec3 parse_axis(std::string_view text) {
  double sign = 1;
  if (!text.empty() && (text[0] == '-' || text[0] == '+')) {
    sign = text[0] == '-' ? -1 : 1;
    text.remove_prefix(1);
  }
  if (text == "x" || text == "X") return sign * Vec3::UnitX();
  if (text == "y" || text == "Y") return sign * Vec3::UnitY();
  if (text == "z" || text == "Z") return sign * Vec3::UnitZ();
  throw Error("unknown axis '" + std::string(text) + "' (valid: x, y, z, -x, -y, -z)");
}

Camera fit_camera(const Bounds& bounds, double aspect, const Vec3& up, double fov_deg, double margin) {
  Bounds b = bounds;
  if (b.empty()) {
    b.extend(Vec3::Constant(-0.5));
    b.extend(Vec3::Constant(0.5));
  }
  // A flat or point-like scene still needs a finite distance.
  const double pad = std::max(1e-3 * b.diagonal(), 1e-6);
  b.lo.array() -= pad;
  b.hi.array() += pad;

  // Right, up and front from the up axis: front is the next axis after up (y-up: front z, right x).
  const Vec3 u = up.normalized();
  int k = 0;
  u.cwiseAbs().maxCoeff(&k);
  const double s = u[k] < 0 ? -1.0 : 1.0;
  const Vec3 front = s * Vec3::Unit((k + 1) % 3);
  const Vec3 right = u.cross(front);
  const Vec3 dir = (0.55 * right + 0.6 * u + 1.0 * front).normalized();  // target -> eye

  Camera cam;
  cam.up = u;
  cam.fov_deg = fov_deg;
  cam.target = b.center();
  cam.eye = cam.target + dir;  // provisional, for the basis
  Vec3 r, tu, f;
  cam.basis(r, tu, f);
  const double shrink = std::clamp(1.0 - 2.0 * margin, 0.1, 1.0);
  const double tv = tan_half(fov_deg) * shrink;
  const double th = tan_half(fov_deg) * std::max(aspect, 1e-3) * shrink;
  // Every corner must project inside the image: |c.r| <= (D - c.dir) tan_h, same vertically.
  double distance = 0;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner((c & 1) ? b.hi.x() : b.lo.x(), (c & 2) ? b.hi.y() : b.lo.y(), (c & 4) ? b.hi.z() : b.lo.z());
    const Vec3 d = corner - cam.target;
    const double toward = d.dot(dir);
    distance = std::max(distance, toward + std::abs(d.dot(r)) / th);
    distance = std::max(distance, toward + std::abs(d.dot(tu)) / tv);
  }
  cam.eye = cam.target + distance * dir;
  return cam;
}

std::optional<Eigen::Vector2d> project(const Camera& camera, int width, int height, const Vec3& p) {
  Vec3 r, u, f;
  camera.basis(r, u, f);
  const Vec3 d = p - camera.eye;
  const double depth = d.dot(f);
  if (depth <= 0) return std::nullopt;
  const double t = tan_half(camera.fov_deg);
  const double aspect = static_cast<double>(width) / height;
  const double sx = d.dot(r) / (depth * t * aspect);  // -1..1 across the image
  const double sy = d.dot(u) / (depth * t);
  return Eigen::Vector2d(0.5 * (sx + 1.0) * width, 0.5 * (1.0 - sy) * height);
}

double pixel_size_at(const Camera& camera, int height, double distance) {
  return 2.0 * distance * tan_half(camera.fov_deg) / std::max(height, 1);
}

}  // namespace ccfr::render
