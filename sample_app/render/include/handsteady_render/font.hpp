#pragma once
// Hershey vector fonts (libhersheyfont, .jhf files of hershey-fonts-data) as strokes.
#include <glm/glm.hpp>

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace hs::render {

class HersheyFont {
 public:
  // A system-installed Hershey font: "rowmans" (Roman simplex, the default), "futural",
  // "timesr", ... (man hershey_font_load; HERSHEY_FONTS_DIR overrides the folder).
  // Throws RenderError when it cannot be loaded.
  explicit HersheyFont(const std::string& name = "rowmans");

  const std::string& name() const { return name_; }
  // Height of the capital H in font units (21 for the Hershey fonts).
  float cap_height() const { return cap_height_; }
  // Advance width of text in font units. Characters without a glyph (non-ASCII bytes)
  // count as '?'.
  float advance(std::string_view text) const;
  // The strokes of text in font units, one polyline per pen stroke: baseline at y = 0,
  // y up, pen starting at x = 0.
  std::vector<std::vector<glm::vec2>> strokes(std::string_view text) const;

 private:
  struct Glyph {
    float width = 0.0f;
    std::vector<std::vector<glm::vec2>> paths;
  };
  const Glyph& glyph(unsigned char c) const;
  std::string name_;
  std::array<Glyph, 256> glyphs_;
  float cap_height_ = 21.0f;
};

}  // namespace hs::render
