#include "ccfr/render/image.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"

// Debian's libstb holds the implementations of stb_image and stb_image_write: only the
// declarations are included here (no STB_*_IMPLEMENTATION). stb_easy_font is header-only C with
// static functions, hence the silenced warnings.
#include <stb_image.h>
#include <stb_image_write.h>
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <stb_easy_font.h>
#pragma GCC diagnostic pop

namespace ccfr::render {

Image::Image(int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b)
    : width(std::max(w, 0)), height(std::max(h, 0)) {
  rgb.resize(static_cast<size_t>(width) * height * 3);
  for (size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = r;
    rgb[i + 1] = g;
    rgb[i + 2] = b;
  }
}

namespace {
void append_bytes(void* context, void* data, int size) {
  auto* out = static_cast<std::string*>(context);
  out->append(static_cast<const char*>(data), static_cast<size_t>(size));
}
}  // namespace

void write_png(const std::filesystem::path& path, const Image& image) {
  if (image.empty()) throw Error("cannot write an empty image to '" + path.string() + "'");
  std::string bytes;
  if (stbi_write_png_to_func(append_bytes, &bytes, image.width, image.height, 3, image.rgb.data(), image.width * 3) ==
      0)
    throw Error("cannot encode PNG '" + path.string() + "'");
  io::write_file_atomic(path, bytes);
}

Image read_png(const std::filesystem::path& path) {
  int w = 0, h = 0, channels = 0;
  std::uint8_t* data = stbi_load(path.string().c_str(), &w, &h, &channels, 3);
  if (data == nullptr) {
    const char* why = stbi_failure_reason();
    throw Error("cannot read image '" + path.string() + "': " + (why ? why : "unknown error"));
  }
  Image img;
  img.width = w;
  img.height = h;
  img.rgb.assign(data, data + static_cast<size_t>(w) * h * 3);
  stbi_image_free(data);
  return img;
}

Image resize(const Image& image, int width, int height) {
  if (image.empty() || width <= 0 || height <= 0) return Image(std::max(width, 0), std::max(height, 0));
  Image out(width, height);
  const double sx = static_cast<double>(image.width) / width;
  const double sy = static_cast<double>(image.height) / height;
  for (int y = 0; y < height; ++y) {
    const double y0 = y * sy, y1 = (y + 1) * sy;
    for (int x = 0; x < width; ++x) {
      const double x0 = x * sx, x1 = (x + 1) * sx;
      // Each source pixel contributes the area of its overlap with the destination pixel.
      double acc[3] = {0, 0, 0}, total = 0;
      for (int iy = static_cast<int>(y0); iy < std::min(static_cast<int>(std::ceil(y1)), image.height); ++iy) {
        const double wy = std::min<double>(iy + 1, y1) - std::max<double>(iy, y0);
        if (wy <= 0) continue;
        for (int ix = static_cast<int>(x0); ix < std::min(static_cast<int>(std::ceil(x1)), image.width); ++ix) {
          const double wx = std::min<double>(ix + 1, x1) - std::max<double>(ix, x0);
          if (wx <= 0) continue;
          const std::uint8_t* p = image.pixel(ix, iy);
          for (int c = 0; c < 3; ++c) acc[c] += wx * wy * p[c];
          total += wx * wy;
        }
      }
      std::uint8_t* q = out.pixel(x, y);
      for (int c = 0; c < 3; ++c)
        q[c] = static_cast<std::uint8_t>(std::clamp(std::lround(acc[c] / std::max(total, 1e-12)), 0L, 255L));
    }
  }
  return out;
}

void blit(Image& dst, const Image& src, int x, int y) {
  for (int sy = 0; sy < src.height; ++sy) {
    const int dy = y + sy;
    if (dy < 0 || dy >= dst.height) continue;
    for (int sx = 0; sx < src.width; ++sx) {
      const int dx = x + sx;
      if (dx < 0 || dx >= dst.width) continue;
      std::copy_n(src.pixel(sx, sy), 3, dst.pixel(dx, dy));
    }
  }
}

namespace {
/// Fills the axis-aligned rectangle [x0, x1) x [y0, y1), blending `rgb` with weight `alpha`.
void fill_rect(Image& img, int x0, int y0, int x1, int y1, const std::uint8_t rgb[3], double alpha) {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, img.width);
  y1 = std::min(y1, img.height);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      std::uint8_t* p = img.pixel(x, y);
      for (int c = 0; c < 3; ++c) p[c] = static_cast<std::uint8_t>(std::lround((1.0 - alpha) * p[c] + alpha * rgb[c]));
    }
}
}  // namespace

void draw_label(Image& image, int x, int y, const std::string& text, int scale) {
  if (text.empty() || image.empty()) return;
  scale = std::max(scale, 1);
  std::string buf_text = text;  // stb_easy_font takes a mutable char*
  const int tw = stb_easy_font_width(buf_text.data()) * scale;
  const int th = 7 * scale;  // cap height of the font; descenders are not used by labels
  const int pad = 2 * scale;
  const std::uint8_t box[3] = {20, 20, 24};
  fill_rect(image, x, y, x + tw + 2 * pad, y + th + 2 * pad, box, 0.6);
  // About 270 bytes per character according to stb_easy_font's documentation.
  std::vector<char> vbuf(buf_text.size() * 400 + 64);
  const int quads =
      stb_easy_font_print(0.0f, 0.0f, buf_text.data(), nullptr, vbuf.data(), static_cast<int>(vbuf.size()));
  const std::uint8_t white[3] = {250, 250, 250};
  for (int q = 0; q < quads; ++q) {
    // Vertex layout: x, y, z as float, then 4 colour bytes; 4 vertices per quad.
    const auto* v = reinterpret_cast<const float*>(vbuf.data() + static_cast<size_t>(q) * 64);
    const float qx0 = v[0], qy0 = v[1], qx1 = v[8], qy1 = v[9];
    const int px0 = x + pad + static_cast<int>(std::lround(std::min(qx0, qx1) * scale));
    const int py0 = y + pad + static_cast<int>(std::lround(std::min(qy0, qy1) * scale));
    const int px1 = x + pad + static_cast<int>(std::lround(std::max(qx0, qx1) * scale));
    const int py1 = y + pad + static_cast<int>(std::lround(std::max(qy0, qy1) * scale));
    fill_rect(image, px0, py0, px1, py1, white, 1.0);
  }
}

Image contact_sheet(const std::vector<Image>& tiles, const std::vector<std::string>& labels, int columns, int gap) {
  if (tiles.empty()) return {};
  if (!labels.empty() && labels.size() != tiles.size())
    throw Error("contact sheet: " + std::to_string(labels.size()) + " labels for " + std::to_string(tiles.size()) +
                " tiles");
  const int tw = tiles.front().width, th = tiles.front().height;
  for (const Image& t : tiles)
    if (t.width != tw || t.height != th) throw Error("contact sheet: tiles differ in size");
  const int n = static_cast<int>(tiles.size());
  columns = std::clamp(columns, 1, n);
  const int rows = (n + columns - 1) / columns;
  Image sheet(columns * tw + (columns + 1) * gap, rows * th + (rows + 1) * gap, 255, 255, 255);
  const int label_scale = std::max(1, th / 120);
  for (int i = 0; i < n; ++i) {
    const int x = gap + (i % columns) * (tw + gap);
    const int y = gap + (i / columns) * (th + gap);
    blit(sheet, tiles[static_cast<size_t>(i)], x, y);
    if (!labels.empty()) draw_label(sheet, x + 2, y + 2, labels[static_cast<size_t>(i)], label_scale);
  }
  return sheet;
}

ImageDifference compare(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height)
    throw Error("cannot compare a " + std::to_string(a.width) + "x" + std::to_string(a.height) + " image with a " +
                std::to_string(b.width) + "x" + std::to_string(b.height) + " one");
  ImageDifference d;
  double sum = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) {
    const int diff = std::abs(static_cast<int>(a.rgb[i]) - static_cast<int>(b.rgb[i]));
    sum += diff;
    d.max = std::max(d.max, diff);
  }
  d.mean = a.rgb.empty() ? 0.0 : sum / static_cast<double>(a.rgb.size());
  return d;
}

}  // namespace ccfr::render
