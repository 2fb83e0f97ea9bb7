#pragma once
/// @file image.hpp
/// 8-bit RGB images: PNG files, box-filter resizing, text labels and contact sheets.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace ccfr::render {

/// An sRGB image, 3 bytes per pixel, rows from top to bottom.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  ///< width * height * 3

  Image() = default;
  /// A `width` by `height` image filled with one colour.
  Image(int w, int h, std::uint8_t r = 0, std::uint8_t g = 0, std::uint8_t b = 0);

  bool empty() const { return width <= 0 || height <= 0; }
  std::uint8_t* pixel(int x, int y) { return rgb.data() + (static_cast<size_t>(y) * width + x) * 3; }
  const std::uint8_t* pixel(int x, int y) const { return rgb.data() + (static_cast<size_t>(y) * width + x) * 3; }
};

/// Writes `image` as a PNG atomically (temporary file, then rename). Throws ccfr::Error on failure.
void write_png(const std::filesystem::path& path, const Image& image);
/// Reads a PNG (or any format stb_image reads) as RGB. Throws ccfr::Error on failure.
Image read_png(const std::filesystem::path& path);

/// Resizes with an area-weighted box filter (exact averaging when shrinking by an integer factor).
Image resize(const Image& image, int width, int height);

/// Copies `src` into `dst` with its top-left corner at (x, y), clipped to `dst`.
void blit(Image& dst, const Image& src, int x, int y);

/// Draws ASCII `text` with stb_easy_font at pixel (x, y) (top-left), each font pixel `scale`
/// image pixels wide, on a dark translucent box so it reads on any background.
void draw_label(Image& image, int x, int y, const std::string& text, int scale = 2);

/// Lays `tiles` (all the same size) out in a grid of `columns` columns separated by `gap`
/// pixels of background, each with its label drawn in the top-left corner.
/// Throws ccfr::Error if the tiles differ in size or `labels` is neither empty nor tiles.size().
Image contact_sheet(const std::vector<Image>& tiles, const std::vector<std::string>& labels, int columns, int gap = 4);

/// Mean and maximum absolute per-channel difference (0..255) of two same-sized images.
/// Throws ccfr::Error if the sizes differ.
struct ImageDifference {
  double mean = 0.0;
  int max = 0;
};
ImageDifference compare(const Image& a, const Image& b);

}  // namespace ccfr::render
