// HoloLens 2 / MRTK CSV -> two-hand track (docs/IMPORTERS.md#mrtk).
#include "handsteady/import.hpp"
#include "handsteady/text_fields.hpp"

#include "import_common.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <istream>
#include <utility>

namespace hs {

namespace {

// MRTK TrackedHandJoint names -> XR joints.
constexpr std::array<std::pair<std::string_view, Joint>, kJointCount> kMrtkNames = {{
    {"Palm", Joint::Palm},
    {"Wrist", Joint::Wrist},
    {"ThumbMetacarpalJoint", Joint::ThumbMetacarpal},
    {"ThumbProximalJoint", Joint::ThumbProximal},
    {"ThumbDistalJoint", Joint::ThumbDistal},
    {"ThumbTip", Joint::ThumbTip},
    {"IndexMetacarpal", Joint::IndexMetacarpal},
    {"IndexKnuckle", Joint::IndexProximal},
    {"IndexMiddleJoint", Joint::IndexIntermediate},
    {"IndexDistalJoint", Joint::IndexDistal},
    {"IndexTip", Joint::IndexTip},
    {"MiddleMetacarpal", Joint::MiddleMetacarpal},
    {"MiddleKnuckle", Joint::MiddleProximal},
    {"MiddleMiddleJoint", Joint::MiddleIntermediate},
    {"MiddleDistalJoint", Joint::MiddleDistal},
    {"MiddleTip", Joint::MiddleTip},
    {"RingMetacarpal", Joint::RingMetacarpal},
    {"RingKnuckle", Joint::RingProximal},
    {"RingMiddleJoint", Joint::RingIntermediate},
    {"RingDistalJoint", Joint::RingDistal},
    {"RingTip", Joint::RingTip},
    {"PinkyMetacarpal", Joint::LittleMetacarpal},
    {"PinkyKnuckle", Joint::LittleProximal},
    {"PinkyMiddleJoint", Joint::LittleIntermediate},
    {"PinkyDistalJoint", Joint::LittleDistal},
    {"PinkyTip", Joint::LittleTip},
}};

int mrtk_joint(std::string_view name) {
  for (const auto& [n, j] : kMrtkNames)
    if (n == name) return idx(j);
  return -1;
}

// The recordings' first (unsuffixed) hand is the right hand: its finger curl has the
// right-hand chirality and it is tracked on the +X side (docs/IMPORTERS.md).
constexpr Hand kFirstHand = Hand::Right;
constexpr Hand kSecondHand = Hand::Left;

struct Column {
  Hand hand = Hand::Right;
  int joint = -1;
  std::string name;  // as in the header, for messages
};

bool parse_int(std::string_view s, int& out) {
  if (s.empty()) return false;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size();
}

// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
long days_from_civil(long y, int m, int d) {
  y -= m <= 2 ? 1 : 0;
  const long era = (y >= 0 ? y : y - 399) / 400;
  const long yoe = y - era * 400;
  const long doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const long doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

// "(x/ y/ z)" -> metres in Unity axes.
bool parse_cell(std::string_view cell, double v[3]) {
  if (cell.size() < 2 || cell.front() != '(' || cell.back() != ')') return false;
  cell = cell.substr(1, cell.size() - 2);
  for (int a = 0; a < 3; ++a) {
    const size_t slash = cell.find('/');
    if ((a < 2) != (slash != std::string_view::npos)) return false;
    std::string_view part = detail::trim(a < 2 ? cell.substr(0, slash) : cell);
    if (a < 2) cell = cell.substr(slash + 1);
    if (!part.empty() && part.front() == '+') part.remove_prefix(1);
    auto [p, ec] = std::from_chars(part.data(), part.data() + part.size(), v[a]);
    if (part.empty() || ec != std::errc() || p != part.data() + part.size() || !std::isfinite(v[a])) return false;
  }
  return true;
}

// Fraction of fully tracked rows whose finger curl has the chirality of the assigned
// hand (OpenXR axes): for a right hand (index_proximal - wrist) x (little_proximal -
// wrist) points out of the palm, the side the fingers curl to.
double chirality_agreement(const std::vector<TrackRow>& rows, Hand hand, int& counted) {
  int agree = 0;
  counted = 0;
  for (const auto& r : rows) {
    if (r.hand != hand || tracked_joint_count(r.pos) != kJointCount) continue;
    const Eigen::Vector3d w = r.pos.row(idx(Joint::Wrist));
    const Eigen::Vector3d n = (Eigen::Vector3d(r.pos.row(idx(Joint::IndexProximal))) - w)
                                  .cross(Eigen::Vector3d(r.pos.row(idx(Joint::LittleProximal))) - w);
    double curl = 0.0;
    for (Joint f : {Joint::IndexProximal, Joint::MiddleProximal, Joint::RingProximal, Joint::LittleProximal}) {
      const int k = idx(f);
      curl += n.dot(Eigen::Vector3d(r.pos.row(k + 3)) - Eigen::Vector3d(r.pos.row(k)));  // tip - proximal
    }
    const bool right_handed = curl > 0.0;
    agree += (right_handed == (hand == Hand::Right)) ? 1 : 0;
    ++counted;
  }
  return counted ? static_cast<double>(agree) / counted : 0.0;
}

}  // namespace

std::optional<double> parse_wall_clock(std::string_view s) {
  s = detail::trim(s);
  // YYYY-MM-DD hh:mm:ss[.fff...]
  if (s.size() < 19 || s[4] != '-' || s[7] != '-' || (s[10] != ' ' && s[10] != 'T') || s[13] != ':' ||
      s[16] != ':')
    return std::nullopt;
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, sec = 0;
  if (!parse_int(s.substr(0, 4), y) || !parse_int(s.substr(5, 2), mo) || !parse_int(s.substr(8, 2), d) ||
      !parse_int(s.substr(11, 2), h) || !parse_int(s.substr(14, 2), mi) || !parse_int(s.substr(17, 2), sec))
    return std::nullopt;
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || sec > 60 || h < 0 || mi < 0 || sec < 0)
    return std::nullopt;
  double frac = 0.0;
  if (s.size() > 19) {
    if (s[19] != '.' || s.size() == 20) return std::nullopt;
    double scale = 0.1;
    for (char c : s.substr(20)) {
      if (c < '0' || c > '9') return std::nullopt;
      frac += scale * (c - '0');
      scale *= 0.1;
    }
  }
  const long days = days_from_civil(y, mo, d);
  return static_cast<double>(days * 86400L + h * 3600L + mi * 60L + sec) + frac;
}

Track parse_mrtk(std::istream& in, const std::string& source_name) {
  std::string line;
  long line_no = 0;
  std::vector<Column> columns;
  // Header.
  while (std::getline(in, line)) {
    ++line_no;
    if (!detail::trim(line).empty()) break;
  }
  if (line_no == 0 || detail::trim(line).empty()) throw InputError({source_name, line_no, ""}, "empty file (no header)");
  {
    const auto names = split_commas(detail::trim(line));
    const std::array<std::string_view, 3> lead = {"Label", "Time", "Counter"};
    if (names.size() != 3 + 2 * kJointCount)
      throw InputError({source_name, line_no, ""},
                       fmt::format("header has {} columns, expected {} (Label,Time,Counter, 26 joints, 26 joints.1)",
                                   names.size(), 3 + 2 * kJointCount));
    for (size_t c = 0; c < 3; ++c)
      if (names[c] != lead[c])
        throw InputError({source_name, line_no, std::string(names[c])},
                         fmt::format("header column {} should be '{}'", c + 1, lead[c]));
    bool seen[2][kJointCount] = {};
    for (size_t c = 3; c < names.size(); ++c) {
      std::string_view n = names[c];
      Hand hand = kFirstHand;
      if (n.size() > 2 && n.substr(n.size() - 2) == ".1") {
        hand = kSecondHand;
        n.remove_suffix(2);
      }
      const int j = mrtk_joint(n);
      if (j < 0)
        throw InputError({source_name, line_no, std::string(names[c])}, "not an MRTK hand joint name");
      bool& s = seen[static_cast<int>(hand)][j];
      if (s) throw InputError({source_name, line_no, std::string(names[c])}, "joint column appears twice");
      s = true;
      columns.push_back({hand, j, std::string(names[c])});
    }
  }

  Track track;
  track.set_meta("source", "mrtk " + source_name);
  track.set_meta("derived", "");
  track.set_meta("conversion", "Unity left-handed (+Y up, +Z forward) -> OpenXR: (x, y, -z); metres");
  track.set_meta("hands", "unsuffixed columns = right, '.1' columns = left");
  double t0 = 0.0, last_t = -1.0;
  bool have_first = false;
  long dropped = 0;
  std::vector<long> dropped_lines;
  size_t kept = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string_view l = detail::trim(line);
    if (l.empty()) continue;
    const auto fields = split_commas(l);
    if (fields.size() != 3 + columns.size())
      throw InputError({source_name, line_no, ""},
                       fmt::format("row has {} fields, expected {}", fields.size(), 3 + columns.size()));
    const auto wall = parse_wall_clock(fields[1]);
    if (!wall)
      throw InputError({source_name, line_no, "Time"},
                       fmt::format("'{}' is not a time 'YYYY-MM-DD hh:mm:ss.mmm'", fields[1]));
    int counter = 0;
    if (!parse_int(fields[2], counter))
      throw InputError({source_name, line_no, "Counter"}, fmt::format("'{}' is not an integer", fields[2]));
    if (!have_first) {
      t0 = *wall;
      have_first = true;
    }
    const double t = *wall - t0;
    Pose pose[2] = {untracked_pose(), untracked_pose()};
    for (size_t c = 0; c < columns.size(); ++c) {
      const std::string_view cell = fields[3 + c];
      if (cell == "0") continue;  // not tracked
      double v[3];
      if (!parse_cell(cell, v))
        throw InputError({source_name, line_no, columns[c].name},
                         fmt::format("'{}' is not a joint cell '(x/ y/ z)' or 0", cell));
      Pose& p = pose[static_cast<int>(columns[c].hand)];
      // Unity is left-handed with +Z forward; OpenXR is right-handed with -Z forward.
      p(columns[c].joint, 0) = v[0];
      p(columns[c].joint, 1) = v[1];
      p(columns[c].joint, 2) = -v[2];
    }
    // Non-increasing wall-clock time (a logging artefact): keep the first row at a time.
    if (kept > 0 && !(t > last_t)) {
      ++dropped;
      if (dropped_lines.size() < 20) dropped_lines.push_back(line_no);
      continue;
    }
    last_t = t;
    ++kept;
    track.rows.push_back({t, Hand::Left, pose[static_cast<int>(Hand::Left)]});
    track.rows.push_back({t, Hand::Right, pose[static_cast<int>(Hand::Right)]});
  }
  if (in.bad()) throw InputError({source_name, line_no, ""}, "read error");
  track.set_meta("rate_hz", kept > 1 && last_t > 0.0 ? fmt::format("{:.2f}", static_cast<double>(kept - 1) / last_t)
                                                     : std::string("0"));
  track.set_meta("timing", "irregular: t = wall-clock Time minus the first row's Time");
  track.set_meta("dropped_rows", std::to_string(dropped));
  if (dropped > 0) {
    std::string lines;
    for (long n : dropped_lines) lines += (lines.empty() ? "" : " ") + std::to_string(n);
    track.add_comment(fmt::format("dropped (Time not after the previous kept row), lines: {}{}", lines,
                                  dropped > static_cast<long>(dropped_lines.size()) ? " ..." : ""));
  }
  for (Hand h : {Hand::Right, Hand::Left}) {
    int counted = 0;
    const double agree = chirality_agreement(track.rows, h, counted);
    if (counted > 0)
      track.set_meta(fmt::format("chirality_check_{}", hand_name(h)),
                     fmt::format("{:.3f} of {} fully tracked rows curl like a {} hand", agree, counted, hand_name(h)));
  }
  return track;
}

Track import_mrtk(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) throw InputError({csv.string(), 0, ""}, "cannot open file");
  return parse_mrtk(in, csv.string());
}

}  // namespace hs
