// FPHA skeleton.txt -> right-hand track (docs/IMPORTERS.md#fpha).
#include "handsteady/import.hpp"

#include "handsteady/text_fields.hpp"
#include "import_common.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <istream>

namespace hs {

namespace {

constexpr int kFphaJoints = 21;
constexpr double kFphaRateHz = 30.0;
constexpr double kMetresPerMm = 0.001;

// FPHA joint order (README) -> XR joint.
constexpr std::array<Joint, kFphaJoints> kFphaToXr = {
    Joint::Wrist,
    Joint::ThumbMetacarpal,  // FPHA "thumb MCP" is the carpometacarpal base
    Joint::IndexProximal, Joint::MiddleProximal, Joint::RingProximal, Joint::LittleProximal,
    Joint::ThumbProximal, Joint::ThumbDistal, Joint::ThumbTip,
    Joint::IndexIntermediate, Joint::IndexDistal, Joint::IndexTip,
    Joint::MiddleIntermediate, Joint::MiddleDistal, Joint::MiddleTip,
    Joint::RingIntermediate, Joint::RingDistal, Joint::RingTip,
    Joint::LittleIntermediate, Joint::LittleDistal, Joint::LittleTip,
};

std::string fpha_field_name(size_t field) {
  if (field == 0) return "frame_index";
  const size_t k = field - 1;
  return fmt::format("{}{}", "xyz"[k % 3], k / 3);
}

void set_fpha_metadata(Track& track, const std::string& source) {
  track.set_meta("source", "fpha " + source);
  track.set_meta("rate_hz", "30");
  track.set_meta("derived", detail::joint_list({idx(Joint::Palm), idx(Joint::IndexMetacarpal), idx(Joint::MiddleMetacarpal),
                                                idx(Joint::RingMetacarpal), idx(Joint::LittleMetacarpal)}));
  track.set_meta("conversion", "mm -> m; camera axes (+Y down, +Z forward) -> OpenXR: (x, -y, -z)");
}

}  // namespace

Track parse_fpha(std::istream& in, const std::string& source_name) {
  Track track;
  set_fpha_metadata(track, source_name);
  std::string line;
  long line_no = 0;
  double last_index = -1.0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto fields = detail::split_ws(line);
    if (fields.empty()) continue;
    if (fields.size() != 1 + 3 * kFphaJoints)
      throw InputError({source_name, line_no, ""},
                       fmt::format("{} fields, expected {} (frame_index x0 y0 z0 ... x20 y20 z20)", fields.size(),
                                   1 + 3 * kFphaJoints));
    const double frame = parse_finite_number(fields[0], {source_name, line_no, "frame_index"});
    if (frame < 0.0 || frame != std::floor(frame))
      throw InputError({source_name, line_no, "frame_index"}, fmt::format("'{}' is not a frame number", fields[0]));
    if (frame <= last_index)
      throw InputError({source_name, line_no, "frame_index"},
                       fmt::format("frame {} does not follow frame {}", frame, last_index));
    last_index = frame;
    TrackRow row;
    row.t = frame / kFphaRateHz;
    row.hand = Hand::Right;
    for (size_t j = 0; j < kFphaJoints; ++j) {
      double v[3];
      for (size_t a = 0; a < 3; ++a) {
        const size_t f = 1 + 3 * j + a;
        v[a] = parse_finite_number(fields[f], {source_name, line_no, fpha_field_name(f)});
      }
      // Camera axes (+Y down, +Z forward) to OpenXR (+Y up, -Z forward): a 180 degree
      // rotation about X, which keeps the frame right-handed.
      const int xr = idx(kFphaToXr[j]);
      row.pos(xr, 0) = kMetresPerMm * v[0];
      row.pos(xr, 1) = -kMetresPerMm * v[1];
      row.pos(xr, 2) = -kMetresPerMm * v[2];
    }
    detail::derive_finger_metacarpals(row.pos);
    detail::derive_palm(row.pos);
    track.rows.push_back(row);
  }
  if (in.bad()) throw InputError({source_name, line_no, ""}, "read error");
  return track;
}

Track import_fpha_file(const std::filesystem::path& skeleton_txt) {
  std::ifstream in(skeleton_txt);
  if (!in) throw InputError({skeleton_txt.string(), 0, ""}, "cannot open file");
  return parse_fpha(in, skeleton_txt.string());
}

namespace {

std::vector<std::filesystem::path> fpha_files(const std::filesystem::path& dir) {
  if (!std::filesystem::is_directory(dir)) throw InputError({dir.string(), 0, ""}, "not a directory");
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename() == "skeleton.txt") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

std::vector<Track> import_fpha_takes(const std::filesystem::path& dir) {
  std::vector<Track> takes;
  for (const auto& f : fpha_files(dir)) {
    takes.push_back(import_fpha_file(f));
    takes.back().set_meta("take", std::filesystem::relative(f, dir).generic_string());
  }
  return takes;
}

Track import_fpha(const std::filesystem::path& file_or_dir) {
  if (!std::filesystem::is_directory(file_or_dir)) return import_fpha_file(file_or_dir);
  std::vector<Track> takes;
  std::vector<std::string> names;
  for (const auto& f : fpha_files(file_or_dir)) {
    takes.push_back(import_fpha_file(f));
    names.push_back(std::filesystem::relative(f, file_or_dir).generic_string());
  }
  if (takes.empty()) throw InputError({file_or_dir.string(), 0, ""}, "no skeleton.txt files under this directory");
  Track out = concatenate_takes(takes, names);
  // Metadata even when every take was empty.
  Track meta;
  set_fpha_metadata(meta, file_or_dir.string());
  for (const auto& l : meta.header_lines) {
    const std::string key = l.substr(0, l.find(':'));
    out.set_meta(key, l.substr(key.size() + 2));
  }
  return out;
}

}  // namespace hs
