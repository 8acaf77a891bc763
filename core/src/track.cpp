#include "handsteady/track.hpp"

#include "handsteady/text_fields.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <fstream>
#include <istream>
#include <limits>
#include <ostream>

namespace hs {

namespace {

constexpr double kAbsurdMetres = 1000.0;  // a coordinate beyond 1 km is not a hand
constexpr int kColumns = 2 + 3 * kJointCount;

bool is_missing(std::string_view f) { return f.empty() || f == "nan" || f == "NaN" || f == "NAN"; }

}  // namespace

std::string_view hand_name(Hand h) { return h == Hand::Left ? "left" : "right"; }

std::optional<Hand> parse_hand(std::string_view s) {
  if (s == "left") return Hand::Left;
  if (s == "right") return Hand::Right;
  return std::nullopt;
}

Pose untracked_pose() { return Pose::Constant(kNaN); }

bool any_joint_tracked(const Pose& p) {
  for (int j = 0; j < kJointCount; ++j)
    if (joint_tracked(p, j)) return true;
  return false;
}

bool repeated_pose(const Pose& a, const Pose& b) noexcept {
  for (int j = 0; j < kJointCount; ++j) {
    if (joint_tracked(a, j) != joint_tracked(b, j)) return false;
    if (joint_tracked(a, j) && !((a.row(j) - b.row(j)).squaredNorm() <= kRepeatToleranceM * kRepeatToleranceM))
      return false;
  }
  return true;
}

int tracked_joint_count(const Pose& p) {
  int n = 0;
  for (int j = 0; j < kJointCount; ++j) n += joint_tracked(p, j) ? 1 : 0;
  return n;
}

std::optional<std::string> Track::meta(std::string_view key) const { return meta_value(header_lines, key); }

void Track::set_meta(std::string_view key, std::string_view value) { set_meta_value(header_lines, key, value); }

void Track::add_comment(std::string_view text) { header_lines.emplace_back(text); }

HandSeries hand_series(const Track& track, Hand hand) {
  HandSeries s;
  for (const auto& r : track.rows) {
    if (r.hand != hand) continue;
    s.t.push_back(r.t);
    s.pos.push_back(r.pos);
  }
  return s;
}

void add_hand_series(Track& track, Hand hand, const HandSeries& series) {
  for (size_t i = 0; i < series.size(); ++i) track.rows.push_back({series.t[i], hand, series.pos[i]});
  std::stable_sort(track.rows.begin(), track.rows.end(), [](const TrackRow& a, const TrackRow& b) {
    if (a.t != b.t) return a.t < b.t;
    return a.hand < b.hand;
  });
}

std::vector<std::string> track_csv_columns() {
  std::vector<std::string> cols = {"t", "hand"};
  for (auto name : xr_joint_names())
    for (const char* axis : {"_x", "_y", "_z"}) cols.push_back(std::string(name) + axis);
  return cols;
}

Track parse_track_csv(std::istream& in, const std::string& source_name) {
  const std::vector<std::string> columns = track_csv_columns();
  Track track;
  std::string line;
  long line_no = 0;
  bool have_header = false;
  double last_t[2] = {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  while (std::getline(in, line)) {
    ++line_no;
    const std::string_view l = trim_field(line);
    if (const auto comment = comment_text(l)) {
      track.header_lines.emplace_back(*comment);
      continue;
    }
    if (l.empty()) continue;
    auto fields = split_commas(l);
    if (!have_header) {
      if (fields.size() != columns.size())
        throw InputError({source_name, line_no, ""},
                         fmt::format("header has {} columns, expected {} (t,hand,palm_x,...,little_tip_z)",
                                     fields.size(), columns.size()));
      for (size_t c = 0; c < columns.size(); ++c)
        if (fields[c] != columns[c])
          throw InputError({source_name, line_no, std::string(fields[c])},
                           fmt::format("header column {} should be '{}'", c + 1, columns[c]));
      have_header = true;
      continue;
    }
    if (fields.size() != static_cast<size_t>(kColumns))
      throw InputError({source_name, line_no, ""},
                       fmt::format("row has {} fields, expected {}", fields.size(), kColumns));
    TrackRow row;
    if (is_missing(fields[0])) throw InputError({source_name, line_no, "t"}, "time is missing");
    row.t = parse_finite_number(fields[0], {source_name, line_no, "t"});
    auto hand = parse_hand(fields[1]);
    if (!hand)
      throw InputError({source_name, line_no, "hand"},
                       "'" + std::string(fields[1]) + "' is not a hand (expected left or right)");
    row.hand = *hand;
    double& last = last_t[static_cast<int>(row.hand)];
    if (!(row.t > last))
      throw InputError({source_name, line_no, "t"},
                       fmt::format("time {} is not after the previous {} hand row's time {}", row.t,
                                   hand_name(row.hand), last));
    last = row.t;
    for (int j = 0; j < kJointCount; ++j) {
      int missing = 0;
      for (int a = 0; a < 3; ++a) {
        const size_t c = static_cast<size_t>(2 + 3 * j + a);
        if (is_missing(fields[c])) {
          ++missing;
          continue;
        }
        const SourceLocation where{source_name, line_no, columns[c]};
        const double v = parse_finite_number(fields[c], where);
        if (std::abs(v) > kAbsurdMetres)
          throw InputError(where, fmt::format("{} m is not a plausible hand position", v));
        row.pos(j, a) = v;
      }
      if (missing != 0 && missing != 3)
        throw InputError({source_name, line_no, columns[static_cast<size_t>(2 + 3 * j)]},
                         "joint '" + std::string(xr_joint_names()[static_cast<size_t>(j)]) +
                             "' is partly given (x, y, z must all be present or all empty)");
      if (missing == 3) row.pos.row(j).setConstant(kNaN);
    }
    track.rows.push_back(row);
  }
  if (!have_header) throw InputError({source_name, line_no, ""}, "no header line (t,hand,palm_x,...) found");
  return track;
}

Track read_track_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError({path.string(), 0, ""}, "cannot open file");
  return parse_track_csv(in, path.string());
}

void write_track_csv(const Track& track, std::ostream& out) {
  for (const auto& l : track.header_lines) out << "# " << l << '\n';
  const auto cols = track_csv_columns();
  for (size_t c = 0; c < cols.size(); ++c) out << (c ? "," : "") << cols[c];
  out << '\n';
  std::string line;
  for (const auto& r : track.rows) {
    line.clear();
    fmt::format_to(std::back_inserter(line), "{:.9f},{}", r.t, hand_name(r.hand));
    for (int j = 0; j < kJointCount; ++j) {
      if (!r.pos.row(j).allFinite()) {
        line += ",,,";
        continue;
      }
      for (int a = 0; a < 3; ++a) {
        double v = r.pos(j, a);
        if (std::abs(v) < 5e-8) v = 0.0;  // no "-0.0000000"
        fmt::format_to(std::back_inserter(line), ",{:.7f}", v);
      }
    }
    line += '\n';
    out << line;
  }
}

void write_track_csv(const Track& track, const std::filesystem::path& path) {
  std::ofstream out(path);
  if (!out) throw InputError({path.string(), 0, ""}, "cannot open file for writing");
  write_track_csv(track, out);
  out.flush();
  if (!out) throw InputError({path.string(), 0, ""}, "write failed");
}

}  // namespace hs
