#include "handsteady/input_noise.hpp"
#include "handsteady/time_series.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>

namespace hs {

namespace {
Eigen::Vector3d at(const float* p) noexcept { return Eigen::Vector3f(p[0], p[1], p[2]).cast<double>(); }
// The largest noise gain of an extrapolation still used: 1 + 3^2 + 3^2 + 1 = 20 on a
// regular grid, 44 when the oldest interval is half the others.
constexpr double kMaxGain2 = 200.0;
// (E|n|)^2 / E n^2 of a Gaussian along any axis: 2 / pi.
constexpr double kGaussianAbs2 = 2.0 / 3.14159265358979323846;
// The joint a jump is judged against: its parent, the wrist's the palm. Joints are judged
// parents first (kXrParentFirst), so a reference has been judged before its joint, except
// the palm before the wrist: the wrist (judged first) is weighed against the palm's
// residual alone.
constexpr std::array<int, kJointCount> kJumpReference = [] {
  std::array<int, kJointCount> r{};
  for (int j = 0; j < kJointCount; ++j) r[static_cast<size_t>(j)] = kXrParent[static_cast<size_t>(j)];
  r[static_cast<size_t>(idx(Joint::Wrist))] = idx(Joint::Palm);
  return r;
}();
// The largest squared sample a running mean of `count` samples takes: kInputNoiseClip^2
// times the mean (at least the floor's), once it has kInputNoiseWarmRows samples.
double clip_bound2(double mean, int count) noexcept {
  if (count < kInputNoiseWarmRows) return std::numeric_limits<double>::infinity();
  return kInputNoiseClip * kInputNoiseClip * std::max(mean, kInputNoiseFloor * kInputNoiseFloor);
}
}  // namespace

void InputNoise::reset() noexcept {
  have_ = 0;
  smooth2_.fill(0.0);
  bone_mean_.fill(0.0);
  bone_var_.fill(0.0);
  jump_.fill(0.0);
  stretched_.fill(false);
  followed_.fill(false);
  noise2_.fill(0.0);
  smooth_n_.fill(0);
  bone_n_.fill(0);
  taint_.fill(0);
  held_.fill(0);
  moved_.fill(false);
  follow_.fill(0);
  returned_.fill(false);
  hand_refit_ = false;
  refit_share_ = 0.0;
  refit_seen_ = 0;
  before_smooth2_.fill(0.0);
  smooth_abs_.fill(0.0);
  before_abs_.fill(0.0);
  shape_.fill(1.0);
  before_n_.fill(0);
  before_held_.fill(0);
  aside_.fill(0);
}

void InputNoise::resume() noexcept {
  const double share = refit_share_;
  const int seen = refit_seen_;
  reset();
  refit_share_ = share;
  refit_seen_ = seen;
}

void InputNoise::push(double t, std::span<const float> x) noexcept {
  if (x.size() < kFs) return;
  // Lagrange weights of the quadratic through the three rows before, at t; white noise
  // of E|n|^2 gives the residual (1 + sum of the weights squared) E|n|^2.
  std::array<double, 3> l{};
  double gain2 = 0.0;
  bool quad = have_ >= 3;
  if (quad) {
    l = quadratic_weights(t, t_[0], t_[1], t_[2]);
    gain2 = 1.0 + l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
    // Rows bunched together (a repeated timestamp nudged apart) make the extrapolation
    // meaningless: no smoothness sample from this row.
    quad = gain2 < kMaxGain2;
  }
  // Each joint's residual from the quadratic (NaN: none in this row).
  std::array<Eigen::Vector3d, kJointCount> res;
  for (size_t ju = 0; ju < kJointCount; ++ju) {
    const size_t o = 3 * ju;
    jump_[ju] = 0.0;
    followed_[ju] = false;
    res[ju].setConstant(std::numeric_limits<double>::quiet_NaN());
    const float* xj = x.data() + o;
    if (quad && finite_xyz(xj) && finite_xyz(rows_[0].data() + o) && finite_xyz(rows_[1].data() + o) &&
        finite_xyz(rows_[2].data() + o))
      res[ju] = at(xj) - l[0] * at(rows_[0].data() + o) - l[1] * at(rows_[1].data() + o) - l[2] * at(rows_[2].data() + o);
  }
  // Each bone's length in this row less its running mean (NaN: an end missing), and which
  // joints' bones stretched (either end): an outlier moves one joint off its bones, a
  // hand's motion, and a tracker's own flip of a finger, keep their lengths.
  std::array<double, kJointCount> stretch;
  stretch.fill(std::numeric_limits<double>::quiet_NaN());
  std::array<bool, kJointCount> strained{};
  stretched_.fill(false);
  for (size_t ju = 0; ju < kJointCount; ++ju) {
    const int parent = kXrParent[ju];
    if (parent < 0) continue;
    const auto pu = static_cast<size_t>(parent);
    const float* xj = x.data() + 3 * ju;
    const float* xp = x.data() + 3 * pu;
    if (finite_xyz(xj) && finite_xyz(xp)) stretch[ju] = (at(xj) - at(xp)).norm() - bone_mean_[ju];
    const double d = stretch[ju];
    const double spread2 = std::max(bone_var_[ju], kInputNoiseStretchFloor * kInputNoiseStretchFloor);
    // Without a length learnt yet there is no evidence: the residual decides alone here
    // (strained), and nothing is reported stretched.
    const bool learnt = std::isfinite(d) && bone_n_[ju] >= kInputNoiseWarmRows;
    const bool off_length = learnt && d * d > kInputNoiseStretch * kInputNoiseStretch * spread2;
    if (!learnt || off_length) strained[ju] = strained[pu] = true;
    if (off_length) stretched_[ju] = stretched_[pu] = true;
  }
  // Smoothness, and which rows are jumps, parents first. A jump's residual, and those of the
  // kQuadRows rows after it (their quadratic runs through it), are held out of the mean:
  // one outlier would otherwise raise the measured noise for the next 30 rows, and with it
  // the bar the next outlier must clear. Held out for more than kInputNoiseHeldRows rows in
  // a row, they are no outliers but a noise that rose, and count (clipped).
  constexpr int kQuadRows = 3;
  std::array<bool, kJointCount> out{};     // this row is a jump held out (its bones too)
  std::array<bool, kJointCount> jumped_now{};  // off the quadratic, stretched or not
  const double bar2 = kInputNoiseJump * kInputNoiseJump * gain2;  // the jump bar over E|n|^2
  for (const int j : kXrParentFirst) {
    const auto ju = static_cast<size_t>(j);
    if (!res[ju].allFinite()) continue;
    // Against the noise measured before this row (an outlier must not explain itself).
    const double r2 = res[ju].squaredNorm();
    bool jumped = r2 > bar2 * noise2_[ju];
    // A joint whose residual its reference joint (no jump) mostly shares moved with the
    // hand, and is a jump only if it also left the reference: a stroke's sharp turn is the
    // whole finger's, an outlier one joint's. A reference that shares little of it (say
    // white noise next to an outlier) leaves the question to the joint's own residual.
    const auto ru = static_cast<size_t>(kJumpReference[ju]);
    if (jumped && res[ru].allFinite() && !jumped_now[ru] && res[ru].dot(res[ju]) > kInputNoiseShared * r2)
      jumped = (res[ju] - res[ru]).squaredNorm() > bar2 * (noise2_[ju] + noise2_[ru]);
    const bool suspect = jumped || taint_[ju] > 0;
    taint_[ju] = jumped ? kQuadRows : std::max(taint_[ju] - 1, 0);
    jumped_now[ju] = jumped;
    // A jump that kept its bones and that the next row stays at (nearer where it jumped
    // to, the last row, than where it came from, the row before) is the tracker's new
    // answer: reported on its first row only, then followed while the quadratic still runs
    // through it.
    const float* xj = x.data() + 3 * ju;
    // This row stays nearer the joint's place `to` rows back than `from` rows back.
    const auto stays = [&](size_t to, size_t from) {
      return finite_xyz(xj) && (at(xj) - at(rows_[to].data() + 3 * ju)).squaredNorm() <
                                   (at(xj) - at(rows_[from].data() + 3 * ju)).squaredNorm();
    };
    const bool confirmed_last = follow_[ju] == kQuadRows - 1;  // the last row confirmed a re-fit
    const bool refit = moved_[ju] && !strained[ju] && stays(0, 1);
    if (moved_[ju] && !returned_[ju]) {  // a candidate's second row: did it stay?
      refit_seen_ = std::min(refit_seen_ + 1, kInputNoiseRefitRows);
      refit_share_ += ((refit ? 1.0 : 0.0) - refit_share_) / refit_seen_;
    }
    if (refit) {
      follow_[ju] = kQuadRows;
    } else if (follow_[ju] > 0 && (strained[ju] || !jumped)) {
      follow_[ju] = 0;
    }
    // A re-fit that stayed a second row is the tracker's (the papers' shifts of two rows in
    // a row come back): its rows were no noise that rose. Their samples leave the mean, and
    // they and the rows it still spoils leave the run of held rows, which two re-fits close
    // together made long enough to count (a thumb's noise then read 10-16 mm on a clean
    // Leap recording, and the trust region let the network hold the old thumb for rows).
    if (confirmed_last && follow_[ju] > 0 && stays(0, 2)) {
      smooth2_[ju] = before_smooth2_[ju];
      std::copy_n(before_abs_.begin() + 3 * ju, 3, smooth_abs_.begin() + 3 * ju);
      smooth_n_[ju] = before_n_[ju];
      held_[ju] = before_held_[ju];
      aside_[ju] = follow_[ju];
    }
    const bool may_refit = jumped && !strained[ju] && follow_[ju] == 0;
    if (may_refit) {
      before_smooth2_[ju] = smooth2_[ju];
      std::copy_n(smooth_abs_.begin() + 3 * ju, 3, before_abs_.begin() + 3 * ju);
      before_n_[ju] = smooth_n_[ju];
      before_held_[ju] = held_[ju];
    }
    moved_[ju] = may_refit;
    // A jump back to within half its length of where the joint was before the row it left
    // (the end of an outlier) is followed as the rest are, but is no re-fit (followed()).
    if (may_refit)
      returned_[ju] = 4.0 * (at(xj) - at(rows_[1].data() + 3 * ju)).squaredNorm() < (at(xj) - at(rows_[0].data() + 3 * ju)).squaredNorm();
    if (jumped && (strained[ju] || follow_[ju] == 0)) jump_[ju] = std::sqrt(r2);
    followed_[ju] = follow_[ju] > 0 && !returned_[ju];
    if (follow_[ju] > 0) --follow_[ju];
    const bool aside = aside_[ju] > 0;
    if (aside) --aside_[ju];
    if (suspect && (aside || held_[ju] < kInputNoiseHeldRows)) {
      if (!aside) ++held_[ju];
      out[ju] = jumped;
      continue;
    }
    if (!suspect) held_[ju] = 0;
    const double sample = std::min(r2 / gain2, clip_bound2(smooth2_[ju], smooth_n_[ju]));
    const double w = running_weight(smooth_n_[ju], kInputNoiseRows);
    smooth2_[ju] += w * (sample - smooth2_[ju]);
    // Per axis, the residual scaled as the sample was (clipped as a whole).
    const double scale = r2 > 0.0 ? std::sqrt(sample / r2) : 0.0;
    Eigen::Map<Eigen::Vector3d> abs_mean(smooth_abs_.data() + 3 * ju);
    abs_mean += w * (scale * res[ju].cwiseAbs() - abs_mean);
  }
  // A rigid move is a chain's: a candidate whose parent and children all stayed is one
  // joint off on its own (an outlier that happened to keep its bone's length).
  std::array<bool, kJointCount> paired{};
  for (size_t ju = 0; ju < kJointCount; ++ju) {
    const int parent = kXrParent[ju];
    if (parent < 0 || !moved_[ju] || !moved_[static_cast<size_t>(parent)]) continue;
    paired[ju] = paired[static_cast<size_t>(parent)] = true;
  }
  // Where this hand's candidates mostly stayed, this row's are followed from now; where
  // they are most of the hand (kInputNoiseHandRefitShare of the joints seen), from now too.
  int seen = 0, candidates = 0;
  for (size_t ju = 0; ju < kJointCount; ++ju) {
    seen += finite_xyz(x.data() + 3 * ju) ? 1 : 0;
    candidates += paired[ju] && !returned_[ju] ? 1 : 0;
  }
  hand_refit_ = seen > 0 && candidates >= kInputNoiseHandRefitShare * seen;
  const bool refits_stay = hand_refit_ || refit_share() > kInputNoiseRefitShare;
  for (size_t ju = 0; ju < kJointCount; ++ju) {
    if (!paired[ju]) moved_[ju] = false;
    if (refits_stay && moved_[ju] && !returned_[ju]) followed_[ju] = true;
  }
  // Rigidity: each bone's length against its running mean, but not in a row where either
  // end is a jump held out above.
  for (size_t ju = 0; ju < kJointCount; ++ju) {
    const int parent = kXrParent[ju];
    if (parent < 0) continue;
    const auto pu = static_cast<size_t>(parent);
    if (!std::isfinite(stretch[ju]) || out[ju] || out[pu]) continue;
    // The spread about the mean before this row (a mean that follows the sample would
    // hide it); the first row only starts the mean. The spread's sample and then the mean's
    // step are clipped alike (the spread has bone_n_ - 1 samples before this row): an
    // outlier's stretched bone moves neither much.
    const double d = stretch[ju];
    if (bone_n_[ju] > 0) {
      const double sample = std::min(d * d, clip_bound2(bone_var_[ju], bone_n_[ju] - 1));
      bone_var_[ju] += (1.0 / std::min<double>(bone_n_[ju], kInputNoiseRows)) * (sample - bone_var_[ju]);
    }
    const double lim = std::sqrt(clip_bound2(bone_var_[ju], bone_n_[ju] - 1));
    bone_mean_[ju] += running_weight(bone_n_[ju], kInputNoiseRows) * std::clamp(d, -lim, lim);
  }
  // A bone's length varies by the noise of both ends along it: 2 sigma^2 per axis with
  // sigma each; E|n|^2 = 3 sigma^2 = 1.5 times that variance.
  for (size_t j = 0; j < kJointCount; ++j) {
    noise2_[j] = std::max(smooth2_[j], 1.5 * bone_var_[j]);
    const double abs2 = Eigen::Map<const Eigen::Vector3d>(smooth_abs_.data() + 3 * j).squaredNorm();
    shape_[j] = smooth2_[j] > 0.0 ? abs2 / (kGaussianAbs2 * smooth2_[j]) : 1.0;
  }
  rows_[2] = rows_[1];
  rows_[1] = rows_[0];
  std::copy(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(kFs), rows_[0].begin());
  t_[2] = t_[1];
  t_[1] = t_[0];
  t_[0] = t;
  have_ = std::min(have_ + 1, 3);
}


}  // namespace hs
