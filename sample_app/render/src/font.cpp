#include "handsteady_render/font.hpp"

#include "handsteady_render/error.hpp"

// hersheyfont.h has no extern "C" of its own.
extern "C" {
#include <hersheyfont.h>
}

#include <algorithm>
#include <memory>

namespace hs::render {

HersheyFont::HersheyFont(const std::string& name) : name_(name) {
  std::unique_ptr<hershey_font, void (*)(hershey_font*)> hf(hershey_font_load(name.c_str()), hershey_font_free);
  if (!hf) {
    throw RenderError("cannot load the Hershey font '" + name +
                      "' (Debian package hershey-fonts-data; HERSHEY_FONTS_DIR sets the folder)");
  }
  for (int c = 0; c < 256; ++c) {
    const hershey_glyph* hg = hershey_font_glyph(hf.get(), static_cast<unsigned char>(c));
    if (hg == nullptr) {
      continue;
    }
    Glyph& g = glyphs_[static_cast<size_t>(c)];
    g.width = static_cast<float>(hg->width);
    for (const hershey_path* p = hg->paths; p != nullptr; p = p->next) {
      std::vector<glm::vec2> path;
      path.reserve(p->nverts);
      for (unsigned i = 0; i < p->nverts; ++i) {
        path.emplace_back(static_cast<float>(p->verts[i].x), static_cast<float>(p->verts[i].y));
      }
      g.paths.push_back(std::move(path));
    }
  }
  const Glyph& h = glyphs_[static_cast<size_t>('H')];
  float top = 0.0f;
  for (const auto& path : h.paths) {
    for (const glm::vec2& v : path) {
      top = std::max(top, v.y);
    }
  }
  if (top > 0.0f) {
    cap_height_ = top;
  }
}

const HersheyFont::Glyph& HersheyFont::glyph(unsigned char c) const {
  const Glyph& g = glyphs_[c];
  return g.width > 0.0f ? g : glyphs_[static_cast<size_t>('?')];
}

float HersheyFont::advance(std::string_view text) const {
  float x = 0.0f;
  for (char ch : text) {
    x += glyph(static_cast<unsigned char>(ch)).width;
  }
  return x;
}

std::vector<std::vector<glm::vec2>> HersheyFont::strokes(std::string_view text) const {
  std::vector<std::vector<glm::vec2>> out;
  float x = 0.0f;
  for (char ch : text) {
    const Glyph& g = glyph(static_cast<unsigned char>(ch));
    for (const auto& path : g.paths) {
      std::vector<glm::vec2> p;
      p.reserve(path.size());
      for (const glm::vec2& v : path) {
        p.emplace_back(v.x + x, v.y);
      }
      out.push_back(std::move(p));
    }
    x += g.width;
  }
  return out;
}

}  // namespace hs::render
