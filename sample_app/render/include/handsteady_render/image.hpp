#pragma once
// RGBA8 images, colours, PNG files and composition (side by side, grids).
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace hs::render {

// One 8-bit RGBA pixel.
struct Rgba8 {
  std::uint8_t r = 0, g = 0, b = 0, a = 255;
  friend bool operator==(const Rgba8&, const Rgba8&) = default;
};

// A drawing colour, RGBA in [0, 1] (written to pixels as round(255 * c), no sRGB curve).
struct Color {
  float r = 0.0f, g = 0.0f, b = 0.0f, a = 1.0f;
  // From 8-bit components: Color::rgb8(255, 128, 0).
  static constexpr Color rgb8(int r8, int g8, int b8, float alpha = 1.0f) {
    return {static_cast<float>(r8) / 255.0f, static_cast<float>(g8) / 255.0f,
            static_cast<float>(b8) / 255.0f, alpha};
  }
  Rgba8 to_rgba8() const;
  friend bool operator==(const Color&, const Color&) = default;
};

// The largest image side hs_render accepts (contexts, images, plots).
inline constexpr int kMaxImageSide = 16384;

// RGBA8 pixels, rows top-down, 4 bytes per pixel, no row padding.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;

  Image() = default;
  // Throws std::invalid_argument unless 1 <= width, height <= kMaxImageSide.
  Image(int width, int height, Rgba8 fill = {});
  bool empty() const { return width == 0 || height == 0; }
  // Pixel (x, y), y = 0 the top row. Throw std::out_of_range outside the image.
  Rgba8 at(int x, int y) const;
  void set(int x, int y, Rgba8 c);
  friend bool operator==(const Image&, const Image&) = default;
};

// Writes a PNG (8-bit RGBA). Throws std::invalid_argument for an empty image and
// RenderError naming the path when the file cannot be written.
void write_png(const std::filesystem::path& path, const Image& image);
// Reads a PNG (any channel count, returned as RGBA8). Throws RenderError naming the path.
Image read_png(const std::filesystem::path& path);

// Copies src into dst with src's top-left at (x, y); parts outside dst are dropped.
void blit(Image& dst, const Image& src, int x, int y);
// Images side by side (each its own width), top-aligned, gap pixels between them;
// background fills the rest.
// Throws std::invalid_argument for no images, an empty image or gap < 0.
Image compose_row(std::span<const Image> images, int gap = 0, Rgba8 background = {});
// Images in rows of `columns` cells (cell = largest width x largest height), gap pixels
// between cells, each image at its cell's top-left. Same errors, and columns < 1.
Image compose_grid(std::span<const Image> images, int columns, int gap = 0, Rgba8 background = {});

}  // namespace hs::render
