// BVH parser, forward kinematics, and the ManipNet hand -> XR track mapping
// (docs/IMPORTERS.md#bvh).
#include "handsteady/import.hpp"

#include "handsteady/text_fields.hpp"
#include "import_common.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <istream>
#include <numbers>

namespace hs {

namespace {

// Bounds on the hierarchy, far above real skeletons (a full body with both hands has
// under 100 joints, chains under 30 deep): they keep the recursive parse off the end of
// the stack and the duplicate-name check (linear per joint) small for any file.
constexpr size_t kMaxJoints = 1024;
constexpr int kMaxDepth = 256;

struct Token {
  std::string_view text;
  long line = 0;
};

class HierarchyParser {
 public:
  HierarchyParser(std::vector<Token> tokens, const std::string& source, long end_line)
      : tokens_(std::move(tokens)), source_(source), end_line_(end_line) {}

  void parse(BvhData& out) {
    expect("HIERARCHY");
    expect("ROOT");
    parse_joint(out, -1, 1);
    if (pos_ != tokens_.size()) fail(tokens_[pos_], "unexpected text after the ROOT joint's closing '}'");
  }

 private:
  [[noreturn]] void fail(const Token& t, const std::string& msg) const {
    throw InputError({source_, t.line, std::string(t.text)}, msg);
  }
  [[noreturn]] void fail_end(const std::string& msg) const { throw InputError({source_, end_line_, ""}, msg); }

  const Token& next(const char* what) {
    if (pos_ >= tokens_.size()) fail_end(fmt::format("file ends where {} was expected", what));
    return tokens_[pos_++];
  }
  const Token& expect(std::string_view keyword) {
    const Token& t = next(std::string(keyword).c_str());
    if (t.text != keyword) fail(t, fmt::format("expected '{}'", keyword));
    return t;
  }
  double number() {
    const Token& t = next("a number");
    return parse_finite_number(t.text, {source_, t.line, std::string(t.text)});
  }
  Eigen::Vector3d offset() {
    Eigen::Vector3d v;
    for (int a = 0; a < 3; ++a) v[a] = number();
    return v;
  }

  static std::optional<BvhChannel> channel(std::string_view s) {
    static constexpr std::array<std::string_view, 6> names = {"Xposition", "Yposition", "Zposition",
                                                              "Xrotation", "Yrotation", "Zrotation"};
    for (size_t i = 0; i < names.size(); ++i)
      if (s == names[i]) return static_cast<BvhChannel>(i);
    return std::nullopt;
  }

  void parse_joint(BvhData& out, int parent, int depth) {
    const Token& name = next("a joint name");
    if (out.joints.size() == kMaxJoints) fail(name, fmt::format("more than {} joints", kMaxJoints));
    if (depth > kMaxDepth) fail(name, fmt::format("joints nested more than {} deep", kMaxDepth));
    BvhJoint joint;
    joint.name = std::string(name.text);
    joint.parent = parent;
    joint.line = name.line;
    if (out.find(joint.name) >= 0) fail(name, "joint name used twice");
    const int self = static_cast<int>(out.joints.size());
    out.joints.push_back(joint);
    expect("{");
    bool have_offset = false, have_channels = false;
    for (;;) {
      const Token& t = next("'}'");
      if (t.text == "OFFSET") {
        if (have_offset) fail(t, "second OFFSET in one joint");
        out.joints[static_cast<size_t>(self)].offset = offset();
        have_offset = true;
      } else if (t.text == "CHANNELS") {
        if (have_channels) fail(t, "second CHANNELS in one joint");
        const Token& n = next("a channel count");
        int count = 0;
        const double v = parse_finite_number(n.text, {source_, n.line, std::string(n.text)});
        if (v < 0 || v > 6 || v != std::floor(v)) fail(n, "channel count must be 0..6");
        count = static_cast<int>(v);
        auto& j = out.joints[static_cast<size_t>(self)];
        j.first_channel = out.channel_count;
        for (int c = 0; c < count; ++c) {
          const Token& ct = next("a channel name");
          auto ch = channel(ct.text);
          if (!ch) fail(ct, "not a channel (Xposition .. Zrotation)");
          j.channels.push_back(*ch);
        }
        out.channel_count += count;
        have_channels = true;
      } else if (t.text == "JOINT") {
        parse_joint(out, self, depth + 1);
      } else if (t.text == "End") {
        expect("Site");
        expect("{");
        expect("OFFSET");
        auto& j = out.joints[static_cast<size_t>(self)];
        if (j.has_end_site) fail(t, "second End Site in one joint");
        j.end_offset = offset();
        j.has_end_site = true;
        expect("}");
      } else if (t.text == "}") {
        if (!have_offset) fail(t, fmt::format("joint '{}' has no OFFSET", joint.name));
        return;
      } else {
        fail(t, "expected OFFSET, CHANNELS, JOINT, End Site or '}'");
      }
    }
  }

  std::vector<Token> tokens_;
  size_t pos_ = 0;
  const std::string& source_;
  long end_line_;
};

// Tokens of one hierarchy line; braces are tokens even when glued to a word.
void tokenize(std::string_view line, long line_no, std::vector<Token>& out) {
  for (auto word : detail::split_ws(line)) {
    size_t start = 0;
    for (size_t i = 0; i <= word.size(); ++i) {
      const bool brace = i < word.size() && (word[i] == '{' || word[i] == '}');
      if (i == word.size() || brace) {
        if (i > start) out.push_back({word.substr(start, i - start), line_no});
        if (brace) out.push_back({word.substr(i, 1), line_no});
        start = i + 1;
      }
    }
  }
}

Eigen::Matrix3d axis_rotation(BvhChannel c, double degrees) {
  const double rad = degrees * std::numbers::pi / 180.0;
  switch (c) {
    case BvhChannel::Xrotation: return Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitX()).toRotationMatrix();
    case BvhChannel::Yrotation: return Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
    case BvhChannel::Zrotation: return Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    default: return Eigen::Matrix3d::Identity();
  }
}

}  // namespace

int BvhData::find(std::string_view name) const {
  for (size_t i = 0; i < joints.size(); ++i)
    if (joints[i].name == name) return static_cast<int>(i);
  return -1;
}

BvhData parse_bvh(std::istream& in, const std::string& source_name) {
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(std::move(l));
  if (in.bad()) throw InputError({source_name, 0, ""}, "read error");
  const long n_lines = static_cast<long>(lines.size());

  // Hierarchy: everything before the MOTION line.
  std::vector<Token> tokens;
  long motion = -1;  // 0-based index of the MOTION line
  for (long i = 0; i < n_lines; ++i) {
    const auto words = detail::split_ws(lines[static_cast<size_t>(i)]);
    if (!words.empty() && words[0] == "MOTION") {
      if (words.size() != 1) throw InputError({source_name, i + 1, std::string(words[1])}, "text after MOTION");
      motion = i;
      break;
    }
    tokenize(lines[static_cast<size_t>(i)], i + 1, tokens);
  }
  if (motion < 0) throw InputError({source_name, n_lines, ""}, "no MOTION section");
  BvhData bvh;
  HierarchyParser(std::move(tokens), source_name, motion + 1).parse(bvh);

  // MOTION header: "Frames: N" and "Frame Time: dt" on the next non-empty lines.
  long i = motion + 1;
  auto next_words = [&](const char* what) {
    while (i < n_lines && detail::split_ws(lines[static_cast<size_t>(i)]).empty()) ++i;
    if (i >= n_lines) throw InputError({source_name, n_lines, ""}, fmt::format("file ends where {} was expected", what));
    return detail::split_ws(lines[static_cast<size_t>(i++)]);
  };
  auto w = next_words("'Frames: N'");
  if (w.size() != 2 || w[0] != "Frames:") throw InputError({source_name, i, "Frames"}, "expected 'Frames: N'");
  const double frames_d = parse_finite_number(w[1], {source_name, i, "Frames"});
  if (frames_d < 0 || frames_d != std::floor(frames_d) || frames_d > 1e8)
    throw InputError({source_name, i, "Frames"}, fmt::format("'{}' is not a frame count", w[1]));
  const auto frames = static_cast<size_t>(frames_d);
  w = next_words("'Frame Time: seconds'");
  if (w.size() != 3 || w[0] != "Frame" || w[1] != "Time:")
    throw InputError({source_name, i, "Frame Time"}, "expected 'Frame Time: seconds'");
  bvh.frame_time = parse_finite_number(w[2], {source_name, i, "Frame Time"});
  if (!(bvh.frame_time > 0.0)) throw InputError({source_name, i, "Frame Time"}, "frame time must be positive");

  // The count is the file's claim: reserve no more than the lines that are left could hold.
  bvh.frames.reserve(std::min(frames, static_cast<size_t>(n_lines - i)));
  for (; i < n_lines; ++i) {
    const auto values = detail::split_ws(lines[static_cast<size_t>(i)]);
    if (values.empty()) continue;
    if (bvh.frames.size() == frames)
      throw InputError({source_name, i + 1, ""}, fmt::format("more frame lines than 'Frames: {}'", frames));
    if (values.size() != static_cast<size_t>(bvh.channel_count))
      throw InputError({source_name, i + 1, ""}, fmt::format("{} values, expected {} (one per channel)", values.size(),
                                                             bvh.channel_count));
    std::vector<double> f(values.size());
    for (size_t c = 0; c < values.size(); ++c)
      f[c] = parse_finite_number(values[c], {source_name, i + 1, fmt::format("channel {}", c + 1)});
    bvh.frames.push_back(std::move(f));
  }
  if (bvh.frames.size() != frames)
    throw InputError({source_name, n_lines, ""},
                     fmt::format("file ends after {} of {} frames", bvh.frames.size(), frames));
  return bvh;
}

BvhData read_bvh(const std::filesystem::path& bvh) {
  std::ifstream in(bvh);
  if (!in) throw InputError({bvh.string(), 0, ""}, "cannot open file");
  return parse_bvh(in, bvh.string());
}

BvhFrame bvh_forward_kinematics(const BvhData& bvh, size_t frame) {
  const auto& values = bvh.frames.at(frame);
  BvhFrame out;
  out.position.resize(bvh.joints.size());
  out.rotation.resize(bvh.joints.size());
  for (size_t j = 0; j < bvh.joints.size(); ++j) {
    const BvhJoint& joint = bvh.joints[j];
    Eigen::Vector3d translation = joint.offset;
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    for (size_t c = 0; c < joint.channels.size(); ++c) {
      const double v = values[static_cast<size_t>(joint.first_channel) + c];
      const BvhChannel ch = joint.channels[c];
      if (ch <= BvhChannel::Zposition)
        translation[static_cast<int>(ch)] += v;
      else
        rotation = rotation * axis_rotation(ch, v);  // channel order = composition order
    }
    if (joint.parent < 0) {
      out.position[j] = translation;
      out.rotation[j] = rotation;
    } else {
      const auto p = static_cast<size_t>(joint.parent);
      out.position[j] = out.position[p] + out.rotation[p] * translation;
      out.rotation[j] = out.rotation[p] * rotation;
    }
  }
  return out;
}

namespace {

// Distal -> tip length as a fraction of the previous bone (intermediate -> distal for
// fingers, proximal -> distal for the thumb): medians over 5,048 fully tracked
// HoloLens 2 hand frames in ../shared/data/hololens2.
constexpr double kThumbTipRatio = 0.55;
constexpr std::array<double, 4> kFingerTipRatio = {0.65, 0.64, 0.81, 0.79};
// XR wrist -> middle_proximal over middle_proximal -> middle_intermediate, median on
// the same HoloLens 2 frames; ManipNet's WRIST sits further up the forearm.
constexpr double kWristToMiddleOverProximal = 1.733;

struct FingerChain {
  const char* bvh[3];   // MCP, PIP, DIP (thumb: CMC_AA, MCP, IP)
  Joint xr[4];          // the three joints and the tip
  double tip_ratio;
};

const std::array<FingerChain, 5>& manipnet_chains() {
  static const std::array<FingerChain, 5> chains = {{
      {{"THUMB_CMC_AA", "THUMB_MCP_FE", "THUMB_IP_FE"},
       {Joint::ThumbMetacarpal, Joint::ThumbProximal, Joint::ThumbDistal, Joint::ThumbTip}, kThumbTipRatio},
      {{"INDEX_MCP", "INDEX_PIP_FE", "INDEX_DIP_FE"},
       {Joint::IndexProximal, Joint::IndexIntermediate, Joint::IndexDistal, Joint::IndexTip}, kFingerTipRatio[0]},
      {{"MIDDLE_MCP", "MIDDLE_PIP_FE", "MIDDLE_DIP_FE"},
       {Joint::MiddleProximal, Joint::MiddleIntermediate, Joint::MiddleDistal, Joint::MiddleTip}, kFingerTipRatio[1]},
      {{"RING_MCP", "RING_PIP_FE", "RING_DIP_FE"},
       {Joint::RingProximal, Joint::RingIntermediate, Joint::RingDistal, Joint::RingTip}, kFingerTipRatio[2]},
      {{"PINKY_MCP", "PINKY_PIP_FE", "PINKY_DIP_FE"},
       {Joint::LittleProximal, Joint::LittleIntermediate, Joint::LittleDistal, Joint::LittleTip}, kFingerTipRatio[3]},
  }};
  return chains;
}

Hand hand_from_name(const std::string& source_name) {
  const std::string file = std::filesystem::path(source_name).filename().string();
  const bool left = file.find("_leftHand") != std::string::npos;
  const bool right = file.find("_rightHand") != std::string::npos;
  if (left == right)
    throw InputError({source_name, 0, ""},
                     "cannot tell the hand from the file name (no '_leftHand' or '_rightHand'); give it explicitly");
  return left ? Hand::Left : Hand::Right;
}

}  // namespace

Track bvh_to_track(const BvhData& bvh, const std::string& source_name, const BvhImportOptions& options) {
  if (!(options.metres_per_unit > 0.0)) throw std::invalid_argument("bvh import: metres_per_unit must be positive");
  const Hand hand = options.hand ? *options.hand : hand_from_name(source_name);
  auto require = [&](const char* name) {
    const int j = bvh.find(name);
    if (j < 0)
      throw InputError({source_name, 0, name},
                       fmt::format("joint '{}' is not in the HIERARCHY (a ManipNet hand skeleton is expected)", name));
    return j;
  };
  const int wrist = require("WRIST");
  struct Resolved {
    std::array<int, 3> joint;
    bool tip_derived;
  };
  std::vector<Resolved> chains;
  std::vector<int> derived = {idx(Joint::Palm), idx(Joint::IndexMetacarpal), idx(Joint::MiddleMetacarpal),
                              idx(Joint::RingMetacarpal), idx(Joint::LittleMetacarpal)};
  for (const auto& c : manipnet_chains()) {
    Resolved r{{require(c.bvh[0]), require(c.bvh[1]), require(c.bvh[2])}, true};
    const BvhJoint& last = bvh.joints[static_cast<size_t>(r.joint[2])];
    // A real end site encodes the tip; a zero-length one (ManipNet) does not.
    r.tip_derived = !(last.has_end_site && last.end_offset.norm() > 0.0);
    if (r.tip_derived) derived.push_back(idx(c.xr[3]));
    chains.push_back(r);
  }

  // Shift of the wrist towards the middle MCP, rigid in the WRIST frame.
  double wrist_shift = 0.0;  // fraction of WRIST -> MIDDLE_MCP
  if (options.relocate_wrist) {
    const double to_mcp = bvh.joints[static_cast<size_t>(chains[2].joint[0])].offset.norm();
    const double proximal = bvh.joints[static_cast<size_t>(chains[2].joint[1])].offset.norm();
    if (to_mcp > 0.0) wrist_shift = std::clamp(1.0 - kWristToMiddleOverProximal * proximal / to_mcp, 0.0, 0.5);
  }

  Track track;
  track.set_meta("source", "bvh " + source_name);
  track.set_meta("rate_hz", fmt::format("{:g}", std::round(1e6 / bvh.frame_time) / 1e6));
  track.set_meta("derived", detail::joint_list(derived));
  track.set_meta("conversion", fmt::format("{} m per unit; Unity left-handed (+Y up, +Z forward) -> OpenXR: (x, y, -z)",
                                           options.metres_per_unit));
  track.set_meta("tip_ratios", fmt::format("thumb {} index {} middle {} ring {} little {} (of the previous bone)",
                                           kThumbTipRatio, kFingerTipRatio[0], kFingerTipRatio[1], kFingerTipRatio[2],
                                           kFingerTipRatio[3]));
  track.set_meta("wrist_shift_mm",
                 fmt::format("{:.1f}", 1000.0 * options.metres_per_unit * wrist_shift *
                                           bvh.joints[static_cast<size_t>(chains[2].joint[0])].offset.norm()));
  track.set_meta("hand", std::string(hand_name(hand)));

  const Eigen::Vector3d to_xr(options.metres_per_unit, options.metres_per_unit, -options.metres_per_unit);
  track.rows.reserve(bvh.frames.size());
  for (size_t f = 0; f < bvh.frames.size(); ++f) {
    const BvhFrame fk = bvh_forward_kinematics(bvh, f);
    TrackRow row;
    row.t = static_cast<double>(f) * bvh.frame_time;
    row.hand = hand;
    auto put = [&](Joint j, const Eigen::Vector3d& p) { row.pos.row(idx(j)) = p.cwiseProduct(to_xr).transpose(); };
    const Eigen::Vector3d w = fk.position[static_cast<size_t>(wrist)];
    const Eigen::Vector3d middle_mcp = fk.position[static_cast<size_t>(chains[2].joint[0])];
    put(Joint::Wrist, w + wrist_shift * (middle_mcp - w));
    for (size_t c = 0; c < chains.size(); ++c) {
      const FingerChain& chain = manipnet_chains()[c];
      for (size_t k = 0; k < 3; ++k) put(chain.xr[k], fk.position[static_cast<size_t>(chains[c].joint[k])]);
      const auto last = static_cast<size_t>(chains[c].joint[2]);
      const Eigen::Vector3d tip_offset =
          chains[c].tip_derived ? Eigen::Vector3d(chain.tip_ratio * bvh.joints[last].offset) : bvh.joints[last].end_offset;
      // The last joint's own rotation bends the extrapolated bone (its offset is the
      // previous bone in the parent frame; rotated by the joint's world rotation).
      put(chain.xr[3], fk.position[last] + fk.rotation[last] * tip_offset);
    }
    detail::derive_finger_metacarpals(row.pos);
    detail::derive_palm(row.pos);
    track.rows.push_back(row);
  }
  return track;
}

Track import_bvh(const std::filesystem::path& bvh) { return import_bvh(bvh, BvhImportOptions{}); }

Track import_bvh(const std::filesystem::path& bvh, const BvhImportOptions& options) {
  return bvh_to_track(read_bvh(bvh), bvh.string(), options);
}

}  // namespace hs
