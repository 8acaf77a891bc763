// Text -> font strokes in world coordinates, through libhersheyfont.
#include "handsteady/error.hpp"
#include "handsteady/handwriting.hpp"

#include <fmt/format.h>
extern "C" {  // a C library whose header has no extern "C" guard
#include <hersheyfont.h>
}

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace hs {

namespace {

struct FontDeleter {
  void operator()(hershey_font* f) const noexcept { hershey_font_free(f); }
};
using FontPtr = std::unique_ptr<hershey_font, FontDeleter>;

FontPtr load_font(const std::string& name) {
  if (name.empty()) throw InputError({"", 0, "font"}, "font name is empty");
  const bool is_file = name.size() > 4 && name.ends_with(".jhf");
  FontPtr font(is_file ? hershey_jhf_font_load(name.c_str()) : hershey_font_load(name.c_str()));
  if (!font)
    throw InputError({"", 0, "font"},
                     fmt::format("cannot load Hershey font '{}' (a name in /usr/share/hershey-fonts, e.g. futural, "
                                 "rowmans, scripts; HERSHEY_FONTS_DIR overrides the folder; or a .jhf path)",
                                 name));
  return font;
}

// Glyph of one character; a width of 0 is how libhersheyfont says "no glyph".
const hershey_glyph& glyph_for(hershey_font& font, char c, size_t position) {
  const hershey_glyph* g = hershey_font_glyph(&font, static_cast<unsigned char>(c));
  if (g == nullptr || g->width == 0) {
    const auto code = static_cast<unsigned>(static_cast<unsigned char>(c));
    const std::string shown = code >= 0x20 && code < 0x7f ? fmt::format("'{}'", c) : fmt::format("byte 0x{:02x}", code);
    throw InputError({"", 0, "text"},
                     fmt::format("character {} at position {} has no glyph in the font", shown, position + 1));
  }
  return *g;
}

// Capital height in font units: the vertical extent of 'H' (21 units in the Hershey
// simplex fonts); fonts without an 'H' fall back to 21.
double cap_height_units(hershey_font& font) {
  const hershey_glyph* g = hershey_font_glyph(&font, static_cast<unsigned char>('H'));
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const hershey_path* p = g ? g->paths : nullptr; p != nullptr; p = p->next)
    for (unsigned short i = 0; i < p->nverts; ++i) {
      lo = std::min(lo, static_cast<double>(p->verts[i].y));
      hi = std::max(hi, static_cast<double>(p->verts[i].y));
    }
  return hi > lo ? hi - lo : 21.0;
}

// Font-unit strokes of the text, glyphs placed by their advance widths (y up, baseline 0).
std::vector<std::vector<Eigen::Vector2d>> text_strokes_units(hershey_font& font, std::string_view text) {
  std::vector<std::vector<Eigen::Vector2d>> out;
  double x0 = 0.0;
  for (size_t i = 0; i < text.size(); ++i) {
    const hershey_glyph& g = glyph_for(font, text[i], i);
    for (const hershey_path* p = g.paths; p != nullptr; p = p->next) {
      std::vector<Eigen::Vector2d> line;
      for (unsigned short k = 0; k < p->nverts; ++k) {
        const Eigen::Vector2d v(x0 + p->verts[k].x, p->verts[k].y);
        if (line.empty() || line.back() != v) line.push_back(v);  // drop repeated vertices
      }
      if (!line.empty()) out.push_back(std::move(line));
    }
    x0 += g.width;
  }
  return out;
}

}  // namespace

double polyline_length(const Polyline& line) {
  double len = 0.0;
  for (size_t i = 1; i < line.size(); ++i) len += (line[i] - line[i - 1]).norm();
  return len;
}

std::vector<Polyline> layout_text(std::string_view text, const TextLayout& layout) {
  if (text.empty()) throw InputError({"", 0, "text"}, "text is empty");
  if (!(layout.letter_height_m > 0.0) || !std::isfinite(layout.letter_height_m))
    throw InputError({"", 0, "letter height"},
                     fmt::format("letter height must be > 0, got {} m", layout.letter_height_m));
  if (!layout.centre.allFinite()) throw InputError({"", 0, "centre"}, "text centre must be finite");
  FontPtr font = load_font(layout.font);
  const auto units = text_strokes_units(*font, text);
  if (units.empty()) throw InputError({"", 0, "text"}, fmt::format("text '{}' has no strokes (only spaces?)", text));
  const double scale = layout.letter_height_m / cap_height_units(*font);
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin;
  for (const auto& line : units)
    for (const auto& v : line) {
      xmin = std::min(xmin, v.x());
      xmax = std::max(xmax, v.x());
    }
  // Ink box centred on centre.x; capital band [0, h] centred on centre.y.
  const double x_mid = 0.5 * (xmin + xmax);
  const double y_mid = 0.5 * layout.letter_height_m;
  std::vector<Polyline> out;
  out.reserve(units.size());
  for (const auto& line : units) {
    Polyline world;
    world.reserve(line.size());
    for (const auto& v : line)
      world.emplace_back(layout.centre.x() + scale * (v.x() - x_mid), layout.centre.y() + scale * v.y() - y_mid,
                         layout.centre.z());
    out.push_back(std::move(world));
  }
  return out;
}

}  // namespace hs
