#pragma once
// Importers from recorded hand motion to tracks (see ../shared/data/README.md and
// docs/IMPORTERS.md for mappings, axes, units and derived joints).
// Each maps to the 26 OpenXR joints (metres, right-handed, +Y up, -Z forward), sets
// "source", "rate_hz" and "derived" (joints computed from others, comma separated)
// metadata, and throws InputError naming file and line on bad input.
#include "handsteady/track.hpp"

#include <Eigen/Core>

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hs {

// FPHA skeleton.txt (21 joints, mm, 30 Hz) -> right hand. Empty files give an empty track.
Track import_fpha_file(const std::filesystem::path& skeleton_txt);
Track parse_fpha(std::istream& in, const std::string& source_name);
// Every skeleton.txt under a directory tree (sorted by path), one track per take.
std::vector<Track> import_fpha_takes(const std::filesystem::path& dir);
// A file or a directory tree; takes are concatenated, each starting 1 s after the
// previous one ends, with one untracked row between them and a "take: <t0> <path>"
// metadata line each.
Track import_fpha(const std::filesystem::path& file_or_dir);

// HoloLens 2 / MRTK CSV (both hands). The unsuffixed joint columns are the right hand,
// the ".1" columns the left hand (checked on the recordings, docs/IMPORTERS.md).
// Rows whose Time is not after the previous kept row are dropped and counted in
// "dropped_rows" metadata.
Track import_mrtk(const std::filesystem::path& csv);
Track parse_mrtk(std::istream& in, const std::string& source_name);
// "YYYY-MM-DD hh:mm:ss[.fff]" -> seconds since 1970-01-01 (UTC, no leap seconds);
// nullopt when malformed.
std::optional<double> parse_wall_clock(std::string_view text);

// ---- BVH ----
enum class BvhChannel { Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation };

struct BvhJoint {
  std::string name;
  int parent = -1;                       // index into BvhData::joints, -1 for the root
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  std::vector<BvhChannel> channels;      // in file order
  int first_channel = 0;                 // index of channels[0] in a frame line
  bool has_end_site = false;
  Eigen::Vector3d end_offset = Eigen::Vector3d::Zero();
  long line = 0;                         // line of its ROOT/JOINT keyword
};

struct BvhData {
  std::vector<BvhJoint> joints;          // parents before children (file order)
  int channel_count = 0;
  double frame_time = 0.0;               // seconds
  std::vector<std::vector<double>> frames;  // channel values, channel_count per frame
  int find(std::string_view name) const;    // joint index or -1
};

// Standard BVH text; throws InputError with file:line (and the token) on bad input.
BvhData parse_bvh(std::istream& in, const std::string& source_name);
BvhData read_bvh(const std::filesystem::path& bvh);

// Forward kinematics of one frame in the file's units and axes: each joint's local
// transform is translation (offset + position channels) then the rotation channels
// composed in file order (R = R_c1 * R_c2 * R_c3, angles in degrees).
struct BvhFrame {
  std::vector<Eigen::Vector3d> position;  // per joint, world
  std::vector<Eigen::Matrix3d> rotation;  // per joint, world orientation
};
BvhFrame bvh_forward_kinematics(const BvhData& bvh, size_t frame);

struct BvhImportOptions {
  std::optional<Hand> hand;         // default: from "_leftHand"/"_rightHand" in the file name
  double metres_per_unit = 0.1;     // ManipNet BVH is in decimetres
  bool relocate_wrist = true;       // move the forearm-side WRIST to the XR wrist (docs)
};
// ManipNet BVH: forward kinematics; fingertips extrapolated (documented in docs/IMPORTERS.md).
Track import_bvh(const std::filesystem::path& bvh);
Track import_bvh(const std::filesystem::path& bvh, const BvhImportOptions& options);
// The same on parsed data (source_name only for messages and metadata).
Track bvh_to_track(const BvhData& bvh, const std::string& source_name, const BvhImportOptions& options);

// Concatenation used by directory imports (see import_fpha).
Track concatenate_takes(const std::vector<Track>& takes, const std::vector<std::string>& names, double gap_s = 1.0);

}  // namespace hs
