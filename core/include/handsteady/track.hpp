#pragma once
// Track data: timestamped 26-joint hand poses for the left and right hand, and the
// documented CSV track format (docs/TRACK_FORMAT.md):
//   '#' lines are metadata/comments ("# key: value" is metadata);
//   header "t,hand,palm_x,palm_y,palm_z,...,little_tip_z";
//   t in seconds, strictly increasing per hand; hand "left" or "right";
//   metres, OpenXR convention (right-handed, +Y up, -Z forward);
//   an empty field or "nan" = joint not tracked; all joints empty = hand not tracked.
#include "handsteady/error.hpp"
#include "handsteady/skeleton.hpp"

#include <Eigen/Core>

#include <cmath>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hs {

enum class Hand : int { Left = 0, Right = 1 };
std::string_view hand_name(Hand h);
std::optional<Hand> parse_hand(std::string_view s);

// One hand's joints, one row per joint (XrHandJointEXT order), metres.
// A row of NaN = that joint is not tracked.
using Pose = Eigen::Matrix<double, kJointCount, 3, Eigen::RowMajor>;
Pose untracked_pose();
inline bool joint_tracked(const Pose& p, int j) { return !std::isnan(p(j, 0)); }
// All three coordinates finite (what filters accept as an observation of the joint).
inline bool joint_finite(const Pose& p, int j) noexcept {
  return std::isfinite(p(j, 0)) && std::isfinite(p(j, 1)) && std::isfinite(p(j, 2));
}
bool any_joint_tracked(const Pose& p);
// A tracker's answer repeated: the same joints tracked, none moved by more than
// kRepeatToleranceM. A sample taken through an app's base space and back differs from the
// runtime's own by float rounding (well under a micrometre); a moving or tracked hand
// moves far more between two samples, and a perfectly still one is a repeat either way.
// The OpenXR layer takes no repeat for a new sample; filter_series, when asked, none that
// follows a row that moved (filters.hpp).
inline constexpr double kRepeatToleranceM = 1e-5;
bool repeated_pose(const Pose& a, const Pose& b) noexcept;
// A joint with all three coordinates finite (what a filter takes for a tracked row).
inline bool any_joint_finite(const Pose& p) noexcept {
  for (int j = 0; j < kJointCount; ++j)
    if (joint_finite(p, j)) return true;
  return false;
}
int tracked_joint_count(const Pose& p);

struct TrackRow {
  double t = 0.0;  // seconds
  Hand hand = Hand::Right;
  Pose pos = untracked_pose();
};

struct Track {
  // Text of each '#' line without the leading '#' and one space, in file order.
  std::vector<std::string> header_lines;
  // Rows in file order (hands interleaved).
  std::vector<TrackRow> rows;

  // Metadata is "key: value" header lines. meta() returns the last value for key.
  std::optional<std::string> meta(std::string_view key) const;
  // Replaces every line for key (or appends one).
  void set_meta(std::string_view key, std::string_view value);
  void add_comment(std::string_view text);
};

// One hand's rows in time order (t strictly increasing).
struct HandSeries {
  std::vector<double> t;
  std::vector<Pose> pos;
  size_t size() const { return t.size(); }
  bool empty() const { return t.empty(); }
};
HandSeries hand_series(const Track& track, Hand hand);
// Appends a series' rows to a track and sorts rows by time (stable: left before right at equal t).
void add_hand_series(Track& track, Hand hand, const HandSeries& series);

// CSV column names: "t", "hand", then "<joint>_x|y|z".
std::vector<std::string> track_csv_columns();

// Reading throws InputError naming file, line and column for: wrong column count,
// unknown header, non-numeric fields, inf, non-finite or missing time, time not
// strictly increasing per hand, bad hand name, a coordinate of a joint partly given,
// absurd magnitudes (|coordinate| > 1000 m).
Track read_track_csv(const std::filesystem::path& path);
Track parse_track_csv(std::istream& in, const std::string& source_name);
// Writes times with 9 decimals (ns) and positions with 7 (0.1 um): a round trip is
// exact to 1e-7 m and a second round trip is byte-identical.
void write_track_csv(const Track& track, const std::filesystem::path& path);
void write_track_csv(const Track& track, std::ostream& out);

}  // namespace hs
