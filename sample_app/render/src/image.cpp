#include "handsteady_render/image.hpp"

#include "handsteady_render/error.hpp"

#include <stb_image.h>
#include <stb_image_write.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>

namespace hs::render {

namespace {

std::uint8_t to_u8(float c) {
  const float v = std::round(std::clamp(c, 0.0f, 1.0f) * 255.0f);
  return static_cast<std::uint8_t>(v);
}

void check_size(int width, int height, const char* what) {
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide) {
    throw std::invalid_argument(std::string(what) + ": size " + std::to_string(width) + "x" +
                                std::to_string(height) + " is not within 1.." + std::to_string(kMaxImageSide));
  }
}

size_t offset(const Image& img, int x, int y) {
  if (x < 0 || y < 0 || x >= img.width || y >= img.height) {
    throw std::out_of_range("pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") outside a " +
                            std::to_string(img.width) + "x" + std::to_string(img.height) + " image");
  }
  return (static_cast<size_t>(y) * static_cast<size_t>(img.width) + static_cast<size_t>(x)) * 4;
}

// stb's PNG writer output goes to a FILE we opened ourselves, so errors keep their errno.
struct PngSink {
  std::FILE* file = nullptr;
  bool ok = true;
  int error = 0;
};

void png_write(void* context, void* data, int size) {
  auto* sink = static_cast<PngSink*>(context);
  if (!sink->ok || size <= 0) {
    return;
  }
  if (std::fwrite(data, 1, static_cast<size_t>(size), sink->file) != static_cast<size_t>(size)) {
    sink->ok = false;
    sink->error = errno;
  }
}

void check_images(std::span<const Image> images, int gap, const char* what) {
  if (images.empty()) {
    throw std::invalid_argument(std::string(what) + ": no images");
  }
  if (gap < 0) {
    throw std::invalid_argument(std::string(what) + ": negative gap");
  }
  for (const Image& img : images) {
    if (img.empty()) {
      throw std::invalid_argument(std::string(what) + ": an empty image");
    }
  }
}

}  // namespace

Rgba8 Color::to_rgba8() const { return {to_u8(r), to_u8(g), to_u8(b), to_u8(a)}; }

Image::Image(int w, int h, Rgba8 fill) : width(w), height(h) {
  check_size(w, h, "Image");
  pixels.resize(static_cast<size_t>(w) * static_cast<size_t>(h) * 4);
  for (size_t i = 0; i < pixels.size(); i += 4) {
    pixels[i] = fill.r;
    pixels[i + 1] = fill.g;
    pixels[i + 2] = fill.b;
    pixels[i + 3] = fill.a;
  }
}

Rgba8 Image::at(int x, int y) const {
  const size_t o = offset(*this, x, y);
  return {pixels[o], pixels[o + 1], pixels[o + 2], pixels[o + 3]};
}

void Image::set(int x, int y, Rgba8 c) {
  const size_t o = offset(*this, x, y);
  pixels[o] = c.r;
  pixels[o + 1] = c.g;
  pixels[o + 2] = c.b;
  pixels[o + 3] = c.a;
}

void write_png(const std::filesystem::path& path, const Image& image) {
  if (image.empty() || image.pixels.size() != static_cast<size_t>(image.width) * static_cast<size_t>(image.height) * 4) {
    throw std::invalid_argument("write_png " + path.string() + ": empty or inconsistent image");
  }
  PngSink sink;
  sink.file = std::fopen(path.c_str(), "wb");
  if (sink.file == nullptr) {
    throw RenderError("cannot write PNG " + path.string() + ": " + std::strerror(errno));
  }
  const int encoded = stbi_write_png_to_func(png_write, &sink, image.width, image.height, 4, image.pixels.data(),
                                             image.width * 4);
  const bool closed = std::fclose(sink.file) == 0;
  if (!closed && sink.ok) {
    sink.ok = false;
    sink.error = errno;
  }
  if (encoded == 0 || !sink.ok) {
    std::error_code ec;
    std::filesystem::remove(path, ec);
    throw RenderError("cannot write PNG " + path.string() + ": " +
                      (encoded == 0 ? std::string("encoding failed") : std::string(std::strerror(sink.error))));
  }
}

Image read_png(const std::filesystem::path& path) {
  int w = 0, h = 0, channels = 0;
  std::unique_ptr<stbi_uc, void (*)(void*)> data(stbi_load(path.c_str(), &w, &h, &channels, 4), stbi_image_free);
  if (!data) {
    const char* why = stbi_failure_reason();
    throw RenderError("cannot read PNG " + path.string() + ": " + (why != nullptr ? why : "unknown error"));
  }
  if (w < 1 || h < 1 || w > kMaxImageSide || h > kMaxImageSide) {
    throw RenderError("cannot read PNG " + path.string() + ": size " + std::to_string(w) + "x" +
                      std::to_string(h) + " is not within 1.." + std::to_string(kMaxImageSide));
  }
  Image img(w, h);
  std::memcpy(img.pixels.data(), data.get(), img.pixels.size());
  return img;
}

void blit(Image& dst, const Image& src, int x, int y) {
  const int x0 = std::max(0, x), y0 = std::max(0, y);
  const int x1 = std::min(dst.width, x + src.width), y1 = std::min(dst.height, y + src.height);
  if (x0 >= x1 || y0 >= y1) {
    return;
  }
  const size_t row_bytes = static_cast<size_t>(x1 - x0) * 4;
  for (int row = y0; row < y1; ++row) {
    const size_t d = (static_cast<size_t>(row) * static_cast<size_t>(dst.width) + static_cast<size_t>(x0)) * 4;
    const size_t s = (static_cast<size_t>(row - y) * static_cast<size_t>(src.width) + static_cast<size_t>(x0 - x)) * 4;
    std::memcpy(dst.pixels.data() + d, src.pixels.data() + s, row_bytes);
  }
}

Image compose_row(std::span<const Image> images, int gap, Rgba8 background) {
  check_images(images, gap, "compose_row");
  long long w = -gap;
  int h = 0;
  for (const Image& img : images) {
    w += img.width + gap;
    h = std::max(h, img.height);
  }
  if (w > kMaxImageSide) {
    throw std::invalid_argument("compose_row: the result would be " + std::to_string(w) + " pixels wide (at most " +
                                std::to_string(kMaxImageSide) + ")");
  }
  Image out(static_cast<int>(w), h, background);
  int x = 0;
  for (const Image& img : images) {
    blit(out, img, x, 0);
    x += img.width + gap;
  }
  return out;
}

Image compose_grid(std::span<const Image> images, int columns, int gap, Rgba8 background) {
  check_images(images, gap, "compose_grid");
  if (columns < 1) {
    throw std::invalid_argument("compose_grid: columns < 1");
  }
  int cell_w = 0, cell_h = 0;
  for (const Image& img : images) {
    cell_w = std::max(cell_w, img.width);
    cell_h = std::max(cell_h, img.height);
  }
  const int n = static_cast<int>(images.size());
  const int cols = std::min(columns, n);
  const int rows = (n + cols - 1) / cols;
  const long long w = static_cast<long long>(cols) * cell_w + static_cast<long long>(cols - 1) * gap;
  const long long h = static_cast<long long>(rows) * cell_h + static_cast<long long>(rows - 1) * gap;
  if (w > kMaxImageSide || h > kMaxImageSide) {
    throw std::invalid_argument("compose_grid: the result would be " + std::to_string(w) + "x" + std::to_string(h) +
                                " pixels (at most " + std::to_string(kMaxImageSide) + " a side)");
  }
  Image out(static_cast<int>(w), static_cast<int>(h), background);
  for (int i = 0; i < n; ++i) {
    blit(out, images[static_cast<size_t>(i)], (i % cols) * (cell_w + gap), (i / cols) * (cell_h + gap));
  }
  return out;
}

}  // namespace hs::render
