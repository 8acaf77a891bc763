// The font strokes CSV ("stroke,x,y,z", '#' metadata lines): docs/HANDWRITING.md.
#include "handsteady/error.hpp"
#include "handsteady/handwriting.hpp"
#include "handsteady/text_fields.hpp"

#include <fmt/format.h>

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <istream>
#include <ostream>

namespace hs {

namespace {

constexpr std::array<std::string_view, 4> kColumns = {"stroke", "x", "y", "z"};
constexpr double kAbsurdMetres = 1000.0;  // same bound as the track reader

double parse_coordinate(std::string_view f, const SourceLocation& where) {
  const double v = parse_finite_number(f, where);
  if (std::abs(v) > kAbsurdMetres) throw InputError(where, fmt::format("{} m is not a plausible position", v));
  return v;
}

long parse_stroke_index(std::string_view f, const SourceLocation& where) {
  long v = 0;
  const auto [ptr, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
  if (f.empty() || ec != std::errc() || ptr != f.data() + f.size() || v < 0)
    throw InputError(where, fmt::format("'{}' is not a stroke index (0, 1, 2, ...)", f));
  return v;
}

void check_header(const std::vector<std::string_view>& fields, const SourceLocation& where) {
  if (fields.size() != kColumns.size())
    throw InputError(where, fmt::format("header has {} columns, expected 4 (stroke,x,y,z)", fields.size()));
  for (size_t c = 0; c < kColumns.size(); ++c)
    if (fields[c] != kColumns[c])
      throw InputError({where.file, where.line, std::string(fields[c])},
                       fmt::format("header column {} should be '{}'", c + 1, kColumns[c]));
}

}  // namespace

std::optional<std::string> StrokeSet::meta(std::string_view key) const { return meta_value(header_lines, key); }

void StrokeSet::set_meta(std::string_view key, std::string_view value) { set_meta_value(header_lines, key, value); }

StrokeSet parse_strokes_csv(std::istream& in, const std::string& source_name) {
  StrokeSet set;
  std::string line;
  long line_no = 0;
  bool have_header = false;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string_view l = trim_field(line);
    if (const auto comment = comment_text(l)) {
      set.header_lines.emplace_back(*comment);
      continue;
    }
    if (l.empty()) continue;
    const auto fields = split_commas(l);
    if (!have_header) {
      check_header(fields, {source_name, line_no, ""});
      have_header = true;
      continue;
    }
    if (fields.size() != kColumns.size())
      throw InputError({source_name, line_no, ""}, fmt::format("row has {} fields, expected 4", fields.size()));
    const long stroke = parse_stroke_index(fields[0], {source_name, line_no, "stroke"});
    const long current = static_cast<long>(set.strokes.size()) - 1;
    if (stroke != current && stroke != current + 1)
      throw InputError({source_name, line_no, "stroke"},
                       fmt::format("stroke {} follows stroke {} (rows of a stroke are consecutive, indices "
                                   "start at 0 and grow by one)",
                                   stroke, current));
    if (stroke == current + 1) set.strokes.emplace_back();
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a)
      p[a] = parse_coordinate(fields[static_cast<size_t>(a + 1)],
                              {source_name, line_no, std::string(kColumns[static_cast<size_t>(a + 1)])});
    set.strokes.back().push_back(p);
  }
  if (!have_header) throw InputError({source_name, line_no, ""}, "no header line (stroke,x,y,z) found");
  return set;
}

StrokeSet read_strokes_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError({path.string(), 0, ""}, "cannot open file");
  return parse_strokes_csv(in, path.string());
}

void write_strokes_csv(const StrokeSet& set, std::ostream& out) {
  for (const auto& l : set.header_lines) out << "# " << l << '\n';
  out << "stroke,x,y,z\n";
  for (size_t s = 0; s < set.strokes.size(); ++s)
    for (const auto& p : set.strokes[s]) out << fmt::format("{},{:.7f},{:.7f},{:.7f}\n", s, p.x(), p.y(), p.z());
}

void write_strokes_csv(const StrokeSet& set, const std::filesystem::path& path) {
  std::ofstream out(path);
  if (!out) throw InputError({path.string(), 0, ""}, "cannot open file for writing");
  write_strokes_csv(set, out);
  out.flush();
  if (!out) throw InputError({path.string(), 0, ""}, "write failed");
}

}  // namespace hs
