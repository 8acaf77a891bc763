#include "import_common.hpp"

#include "handsteady/import.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>

namespace hs::detail {

void derive_finger_metacarpals(Pose& p) {
  const int wrist = idx(Joint::Wrist);
  const std::array<Joint, 4> meta = {Joint::IndexMetacarpal, Joint::MiddleMetacarpal, Joint::RingMetacarpal,
                                     Joint::LittleMetacarpal};
  const std::array<Joint, 4> prox = {Joint::IndexProximal, Joint::MiddleProximal, Joint::RingProximal,
                                     Joint::LittleProximal};
  for (size_t f = 0; f < 4; ++f) {
    if (!joint_tracked(p, wrist) || !joint_tracked(p, idx(prox[f]))) continue;
    p.row(idx(meta[f])) = p.row(wrist) + kMetacarpalRatio[f] * (p.row(idx(prox[f])) - p.row(wrist));
  }
}

void derive_palm(Pose& p) {
  const int a = idx(Joint::MiddleMetacarpal), b = idx(Joint::MiddleProximal);
  if (!joint_tracked(p, a) || !joint_tracked(p, b)) return;
  p.row(idx(Joint::Palm)) = 0.5 * (p.row(a) + p.row(b));
}

std::string joint_list(const std::vector<int>& joints) {
  std::vector<int> sorted = joints;
  std::sort(sorted.begin(), sorted.end());
  std::string out;
  for (int j : sorted) {
    if (!out.empty()) out += ',';
    out += xr_joint_names()[static_cast<size_t>(j)];
  }
  return out;
}

std::string_view trim(std::string_view s) {
  auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!s.empty() && space(s.front())) s.remove_prefix(1);
  while (!s.empty() && space(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_ws(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

}  // namespace hs::detail

namespace hs {

Track concatenate_takes(const std::vector<Track>& takes, const std::vector<std::string>& names, double gap_s) {
  if (names.size() != takes.size())
    throw std::invalid_argument("concatenate_takes: one name per take is required");
  if (!(gap_s > 0.0) || !std::isfinite(gap_s))
    throw std::invalid_argument("concatenate_takes: gap_s must be positive");
  Track out;
  std::vector<std::string> take_lines, empty_lines;
  double start = 0.0;  // time the next take starts at
  bool have_previous = false;
  double previous_end = 0.0;
  bool previous_hands[2] = {false, false};
  for (size_t k = 0; k < takes.size(); ++k) {
    const Track& take = takes[k];
    if (take.rows.empty()) {
      empty_lines.push_back(names[k]);
      continue;
    }
    // Metadata of the first non-empty take (source format, rate, derived joints).
    if (!have_previous)
      for (const auto& l : take.header_lines)
        if (l.rfind("source:", 0) != 0) out.header_lines.push_back(l);
    double t_first = take.rows.front().t, t_last = take.rows.front().t;
    bool hands[2] = {false, false};
    for (const auto& r : take.rows) {
      t_first = std::min(t_first, r.t);
      t_last = std::max(t_last, r.t);
      hands[static_cast<int>(r.hand)] = true;
    }
    if (have_previous) {
      // One untracked row per hand between takes, so no interpolation bridges them.
      const double mid = previous_end + 0.5 * gap_s;
      for (int h = 0; h < 2; ++h)
        if (hands[h] || previous_hands[h]) out.rows.push_back({mid, static_cast<Hand>(h), untracked_pose()});
      start = previous_end + gap_s;
    }
    take_lines.push_back(fmt::format("take: {:.6f} {}", start, names[k]));
    for (const auto& r : take.rows) out.rows.push_back({r.t - t_first + start, r.hand, r.pos});
    previous_end = t_last - t_first + start;
    previous_hands[0] = hands[0];
    previous_hands[1] = hands[1];
    have_previous = true;
  }
  for (auto& l : take_lines) out.header_lines.push_back(std::move(l));
  for (auto& n : empty_lines) out.header_lines.push_back("empty_take: " + n);
  out.set_meta("takes", std::to_string(take_lines.size()));
  return out;
}

}  // namespace hs
