#include "handsteady/correction_bound.hpp"
#include "handsteady/palm_fit.hpp"
#include "handsteady/time_series.hpp"
#include "handsteady/rigid_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hs {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// A ring's entry for a frame that has none (the joint unseen, or no frame yet).
Eigen::Vector3d none() noexcept { return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()); }

Eigen::Vector3d load(const float* p) noexcept { return Eigen::Vector3f(p[0], p[1], p[2]).cast<double>(); }
void store(const Eigen::Vector3d& v, float* p) noexcept {
  for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(v[c]);
}
// p moved the shortest way into the ball of radius r around centre.
Eigen::Vector3d clamp_into(const Eigen::Vector3d& p, const Eigen::Vector3d& centre, double r) noexcept {
  const Eigen::Vector3d d = p - centre;
  const double n = d.norm();
  return n > r ? Eigen::Vector3d(centre + d * (r / n)) : p;
}
// One step of a running mean towards `sample`, clipped to `step`. `spread2` follows half
// the squared change between successive samples: their variance, blind to a constant or
// slowly moving mean (so an offset not yet learnt does not count as spread). `last` is the
// previous sample (NaN: none).
void mean_step(Eigen::Vector3d& mean, double& spread2, Eigen::Vector3d& last, int& count, const Eigen::Vector3d& sample,
               double step) noexcept {
  const double w = running_weight(count, kCorrectionBiasFrames);
  if (last.allFinite()) spread2 += w * (0.5 * (sample - last).squaredNorm() - spread2);
  last = sample;
  mean += w * (clamp_into(sample, mean, step) - mean);
}
// The hand's motion from frame `from` onto frame `to`: the rotation and translation that take
// the palm joints seen in both onto each other, less those whose distances to the others
// changed by over kPalmMotionOff times the median joint's (at least kPalmMotionFloorM): an
// outlier the palm fit let through, a finger base that flexed (false: too few to fix it).
constexpr double kPalmMotionOff = 3.0;
constexpr double kPalmMotionFloorM = 0.002;
bool palm_motion(const float* from, const float* to, Rigid& out) noexcept {
  constexpr size_t kP = kPalmJoints.size();
  std::array<Eigen::Vector3d, kP> a, b;
  std::array<bool, kP> use{};
  for (size_t i = 0; i < kP; ++i) {
    const size_t o = 3 * static_cast<size_t>(kPalmJoints[i]);
    use[i] = finite_xyz(from + o) && finite_xyz(to + o);
    a[i] = use[i] ? load(from + o) : Eigen::Vector3d::Zero();
    b[i] = use[i] ? load(to + o) : Eigen::Vector3d::Zero();
  }
  std::array<double, kP> score{}, sorted{};
  distance_scores(a, b, use, 1.0, score);
  size_t n = 0;
  for (size_t i = 0; i < kP; ++i)
    if (use[i]) sorted[n++] = score[i];
  if (n < 3) return false;
  std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.begin() + n);
  const double cut = std::max(kPalmMotionOff * sorted[n / 2], kPalmMotionFloorM);
  for (size_t i = 0; i < kP; ++i) use[i] = use[i] && score[i] <= cut;
  if (!kabsch(a, b, use, out, false)) return false;
  // A palm that did not move as one body (half of it turned away: a fit in front that
  // failed on many shifted joints) says nothing of what the hand did.
  for (size_t i = 0; i < kP; ++i)
    if (use[i] && (out.apply(a[i]) - b[i]).norm() > kPalmMotionFloorM) return false;
  return true;
}
// The hand's motion from frames x2 and x1 (the two before) onto x0, for a joint's second
// difference in the hand's own frame: what the joint did against its hand, which an outlier
// does and a hand that sweeps, stops or turns as a whole does not. It counts only where it
// explains the fingers' motion too (most of them moved less against it than in the world):
// a palm that turned while the fingers stayed is an error in front (the palm fit misled by
// many shifted joints, the `paper` preset's), not the hand's motion.
// |p0 - 2 p1 + p2| with the two frames before moved onto this one by the hand's motion.
double hand_second_difference(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                              const Rigid& from1, const Rigid& from2) noexcept {
  return (p0 - 2.0 * from1.apply(p1) + from2.apply(p2)).norm();
}
bool hand_motion(const float* x2, const float* x1, const float* x0, Rigid& from2, Rigid& from1) noexcept {
  if (!palm_motion(x1, x0, from1) || !palm_motion(x2, x0, from2)) return false;
  int with = 0, against = 0;
  for (int j = 0; j < kJointCount; ++j) {
    if (is_palm_joint(j)) continue;
    const size_t o = 3 * static_cast<size_t>(j);
    if (!finite_xyz(x0 + o) || !finite_xyz(x1 + o) || !finite_xyz(x2 + o)) continue;
    const Eigen::Vector3d p0 = load(x0 + o), p1 = load(x1 + o), p2 = load(x2 + o);
    const double world = (p0 - 2.0 * p1 + p2).norm();
    const double hand = hand_second_difference(p0, p1, p2, from1, from2);
    ++(hand < world ? with : against);
  }
  return with > against;
}
// The part of a running mean that stands out of its own noise: shrunk towards zero by two
// standard errors (spread * sqrt(w / 2) for an exponential mean of weight w), so a mean of
// large random corrections (outliers taken back) is not applied as an offset.
Eigen::Vector3d significant(const Eigen::Vector3d& mean, double spread2, int count) noexcept {
  int next = count;
  const double w = running_weight(next, kCorrectionBiasFrames);
  const double se2 = 2.0 * std::sqrt(spread2 * w / 2.0);
  const double n = mean.norm();
  return n > se2 ? Eigen::Vector3d(mean * (1.0 - se2 / n)) : Eigen::Vector3d::Zero();
}
// The whole hand's share of a frame's corrections: their median over the joints, each axis,
// of the joints whose row is no jump (radius at its noise: an outlier taken back is no
// share of the hand's); zero where there are none.
Eigen::Vector3d whole_hand_share(const std::array<Eigen::Vector3d, kJointCount>& c,
                                 const std::array<double, kJointCount>& radius,
                                 const std::array<double, kJointCount>& noise_radius) noexcept {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  std::array<double, kJointCount> v{};
  for (int axis = 0; axis < 3; ++axis) {
    size_t n = 0;
    for (size_t j = 0; j < kJointCount; ++j)
      if (c[j].allFinite() && !(radius[j] > noise_radius[j])) v[n++] = c[j][axis];
    if (n == 0) return m;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(n / 2), v.begin() + static_cast<long>(n));
    m[axis] = v[n / 2];
  }
  return m;
}
}  // namespace

CorrectionBound::CorrectionBound(int frames)
    : frames_(std::max(frames, 1)),
      hist_(std::max(frames_, 3)),
      x_(static_cast<size_t>(hist_) * kFs),
      disp_(static_cast<size_t>(hist_ * (frames_ - 1)) * kFs),
      bias_(static_cast<size_t>(frames_ * kJointCount)),
      spread_(static_cast<size_t>(frames_ * kJointCount)),
      last_(static_cast<size_t>(frames_ * kJointCount)),
      bias_count_(static_cast<size_t>(frames_ * kJointCount)),
      corr_(static_cast<size_t>(hist_) * kJointCount),
      applied_(static_cast<size_t>(hist_ * (frames_ - 1)) * kJointCount),
      den_(static_cast<size_t>(hist_) * kJointCount),
      pred_noise2_(static_cast<size_t>(frames_ * kJointCount)),
      pred_power2_(static_cast<size_t>(frames_ * kJointCount)),
      pred_count_(static_cast<size_t>(frames_ * kJointCount)),
      gain_out_(static_cast<size_t>(hist_ * (frames_ - 1)) * kJointCount),
      cv_less_(static_cast<size_t>(hist_ * (frames_ - 1)) * kJointCount),
      blend_num_(static_cast<size_t>(frames_)),
      blend_den_(static_cast<size_t>(frames_)),
      row_num_(static_cast<size_t>(frames_)),
      row_den_(static_cast<size_t>(frames_)),
      blend_count_(static_cast<size_t>(frames_)) {
  reset();
}

void CorrectionBound::reset() noexcept {
  n_ = 0;
  std::fill(x_.begin(), x_.end(), kNaNf);
  std::fill(disp_.begin(), disp_.end(), kNaNf);
  rough_.fill(0.0);
  rough_before_.fill(0.0);
  rough_hand_.fill(0.0);
  rough_hand_before_.fill(0.0);
  hand_jump_.fill(0.0);
  count_.fill(0);
  radius_.fill(kInf);
  std::fill(bias_.begin(), bias_.end(), Eigen::Vector3d::Zero());
  std::fill(spread_.begin(), spread_.end(), 0.0);
  std::fill(last_.begin(), last_.end(), none());
  std::fill(bias_count_.begin(), bias_count_.end(), 0);
  corr2_.fill(0.0);
  corr_count_.fill(0);
  std::fill(corr_.begin(), corr_.end(), none());
  corr_lag1_.fill(0.0);
  corr_lag2_.fill(0.0);
  std::fill(applied_.begin(), applied_.end(), none());
  std::fill(den_.begin(), den_.end(), none());
  std::fill(pred_noise2_.begin(), pred_noise2_.end(), 0.0);
  std::fill(pred_power2_.begin(), pred_power2_.end(), 0.0);
  std::fill(pred_count_.begin(), pred_count_.end(), 0);
  std::fill(gain_out_.begin(), gain_out_.end(), none());
  std::fill(cv_less_.begin(), cv_less_.end(), none());
  for (auto* v : {&blend_num_, &blend_den_, &row_num_, &row_den_}) std::fill(v->begin(), v->end(), 0.0);
  std::fill(blend_count_.begin(), blend_count_.end(), 0);
}

const float* CorrectionBound::x_back(long back) const noexcept {
  return x_.data() + ring(back) * kFs;
}

const Eigen::Vector3d& CorrectionBound::corr_back(long back, size_t joint) const noexcept {
  return corr_[ring(back) * kJointCount + joint];
}

size_t CorrectionBound::predicted_slot(long back, size_t f, size_t joint) const noexcept {
  return (ring(back) * static_cast<size_t>(frames_ - 1) + f - 1) * kJointCount + joint;
}

Eigen::Vector3d& CorrectionBound::applied_back(long back, size_t f, size_t joint) noexcept {
  return applied_[predicted_slot(back, f, joint)];
}

Eigen::Vector3d& CorrectionBound::den_back(long back, size_t joint) noexcept { return den_[ring(back) * kJointCount + joint]; }

Eigen::Vector3d& CorrectionBound::gain_out_back(long back, size_t f, size_t joint) noexcept {
  return gain_out_[predicted_slot(back, f, joint)];
}

Eigen::Vector3d& CorrectionBound::cv_less_back(long back, size_t f, size_t joint) noexcept {
  return cv_less_[predicted_slot(back, f, joint)];
}

double CorrectionBound::correlated_noise2(size_t j, const Eigen::Vector3d& c) noexcept {
  const double w = running_weight(corr_count_[j], kCorrectionBiasFrames);
  corr2_[j] += w * (c.squaredNorm() - corr2_[j]);
  // The frames before may be missing (the joint unseen, a jump): their products are skipped.
  if (n_ >= 1 && corr_back(1, j).allFinite()) corr_lag1_[j] += w * (c.dot(corr_back(1, j)) - corr_lag1_[j]);
  if (n_ >= 2 && corr_back(2, j).allFinite()) corr_lag2_[j] += w * (c.dot(corr_back(2, j)) - corr_lag2_[j]);
  corr_[ring(0) * kJointCount + j] = c;
  return std::max(0.0, corr2_[j] - std::min(corr_lag1_[j], corr_lag2_[j]));
}

Eigen::Vector3d CorrectionBound::gained(size_t f, size_t j, const Eigen::Vector3d& e, const Eigen::Vector3d& went,
                                        size_t first) noexcept {
  const size_t b = f * kJointCount + j;
  applied_back(0, f, j) = e;
  if (f < first) return e;
  if (went.allFinite()) {  // the displacement made f frames ago (went is NaN before then), against where the input went since
    const Eigen::Vector3d& e_then = applied_back(static_cast<long>(f), f, j);
    if (e_then.allFinite()) {
      const double w = running_weight(pred_count_[b], kPredictionNoiseFrames);
      pred_noise2_[b] += w * (e_then.squaredNorm() - e_then.dot(went) - pred_noise2_[b]);
    }
  }
  pred_power2_[b] += (1.0 / kPredictionPowerFrames) * (e.squaredNorm() - pred_power2_[b]);
  const double noise2 = std::max(pred_noise2_[b], 0.0);
  if (!(pred_power2_[b] > 0.0) || noise2 <= 0.0) return e;
  const double warm = std::min(1.0, static_cast<double>(pred_count_[b]) / kPredictionGainWarmRows);
  return e * (1.0 - warm * std::min(1.0, noise2 / pred_power2_[b]));
}

Eigen::Vector3d CorrectionBound::blended(size_t f, size_t j, const Eigen::Vector3d& g, const Eigen::Vector3d& c,
                                         const Eigen::Vector3d& went) noexcept {
  gain_out_back(0, f, j) = g;
  const Eigen::Vector3d q = c - g;
  cv_less_back(0, f, j) = q;
  if (went.allFinite()) {  // the pair made f frames ago (went is NaN before then), against where the input went since
    const auto back = static_cast<long>(f);
    const Eigen::Vector3d& g_then = gain_out_back(back, f, j);
    const Eigen::Vector3d& q_then = cv_less_back(back, f, j);
    if (g_then.allFinite() && q_then.allFinite()) {
      row_num_[f] += q_then.dot(went - g_then);
      row_den_[f] += q_then.squaredNorm();
    }
  }
  if (!q.allFinite() || !(blend_den_[f] > 0.0)) return g;
  const double warm = std::min(1.0, static_cast<double>(blend_count_[f]) / kPredictionGainWarmRows);
  return g + warm * std::clamp(blend_num_[f] / blend_den_[f], 0.0, 1.0) * q;
}

void CorrectionBound::apply(std::span<const float> x, std::span<float> path, const RowEvidence& row) noexcept {
  const std::span<const double> noise2 = row.noise2, jump = row.jump, shape = row.shape;
  const std::span<const bool> followed = row.followed, stretched = row.stretched;
  const double measured_max_rms = row.measured_max_rms;
  const bool followed_hand = row.followed_hand;
  const bool have_shape = shape.size() >= kJointCount;
  const bool have_stretched = stretched.size() >= kJointCount;
  const bool have_followed = followed.size() >= kJointCount;
  const bool have_measured = noise2.size() >= kJointCount && jump.size() >= kJointCount;
  const auto gain_from = static_cast<size_t>(have_measured ? kPredictionGainFirstFrameMeasured : kPredictionGainFirstFrame);
  const auto F = static_cast<size_t>(frames_);
  if (x.size() < kFs || path.size() < kFs * F) return;
  // The ring's slot for this frame: the input, and the network's displacements.
  const size_t slot = ring(0);
  float* x_now = x_.data() + slot * kFs;
  std::copy(x.begin(), x.begin() + kFs, x_now);
  float* disp_now = disp_.data() + slot * (F - 1) * kFs;
  std::fill(disp_now, disp_now + (F - 1) * kFs, kNaNf);
  std::fill(row_num_.begin(), row_num_.end(), 0.0);
  std::fill(row_den_.begin(), row_den_.end(), 0.0);
  // The hand's motion from each of the two frames before onto this one, where the palm
  // moved as one body and that explains the fingers too (hand_motion); found when a joint
  // first needs it (where the noise is measured, most rows none does).
  Rigid from1, from2;
  int hand_frame = n_ >= 2 ? -1 : 0;  // -1: not looked for yet
  // Per joint, from the first pass to the second: the correction before the radius (NaN:
  // the joint is not bound), the RMS second difference, this row's, the noise radius, the
  // radius in the hand's frame.
  std::array<Eigen::Vector3d, kJointCount> cs;
  std::array<double, kJointCount> s_of{}, a_of{}, nr_of{}, rh_of{};
  cs.fill(none());
  for (int j = 0; j < kJointCount; ++j) {
    const auto ju = static_cast<size_t>(j);
    const size_t o = 3 * ju;
    radius_[ju] = kInf;
    corr_[slot * kJointCount + ju] = none();
    den_back(0, ju) = none();
    for (size_t f = 1; f < F; ++f) applied_back(0, f, ju) = gain_out_back(0, f, ju) = cv_less_back(0, f, ju) = none();
    const double jump_before = hand_jump_[ju];  // the row before's jump against the hand (0: none, or unseen)
    hand_jump_[ju] = 0.0;
    if (!finite_xyz(x_now + o)) continue;
    const Eigen::Vector3d xn = load(x_now + o);
    const float* x1 = n_ >= 1 ? x_back(1) + o : nullptr;
    const float* x2 = n_ >= 2 ? x_back(2) + o : nullptr;
    const bool have1 = x1 && finite_xyz(x1), have2 = have1 && x2 && finite_xyz(x2);
    // The noise radius is the history's: this frame's own second difference only widens
    // the radius (an outlier is taken back) and does not yet count as noise.
    // A row that follows a re-fit (InputNoise::followed: a jump that kept its bones and
    // stayed, the tracker's new answer) is no noise: the re-fit's row is taken back out of
    // the roughness, and this row's second difference (the re-fit again) neither enters it
    // nor opens the radius. Left in, one 90 mm re-fit made the noise radius 30 mm for a
    // second, and the network held the old finger.
    // On a whole hand's own row (`followed_hand`) the row before is no re-fit's but the
    // hand's motion setting off: it stays, and this row's second difference enters as any
    // row's (the row after, which follows it, takes it back). Taken out, the 50 ms answers
    // of the 20 Hz tuning split lost 0.08 % (docs/STGAE.md "Most of the hand in one row").
    const bool refit = have_followed && followed[ju];
    const bool refit_noise = refit && !followed_hand;  // the row before's and this row's samples leave the roughness
    if (refit_noise) rough_[ju] = rough_before_[ju], rough_hand_[ju] = rough_hand_before_[ju];
    rough_before_[ju] = rough_[ju];
    rough_hand_before_[ju] = rough_hand_[ju];
    const double s = std::sqrt(rough_[ju]);  // RMS second difference
    const bool measured = have_measured && (noise2[ju] <= measured_max_rms * measured_max_rms ||
                                            (have_shape && shape[ju] >= kMeasuredNoiseMinShape));
    const double noise_r = measured ? kMeasuredNoiseFactor * std::sqrt(noise2[ju]) : kCorrectionNoiseFactor * s / std::sqrt(6.0);
    // The same noise read in the hand's frame (rough_hand_): what bounds the joint's own
    // correction against its hand (below).
    const double noise_rh = measured ? noise_r : kCorrectionNoiseFactor * std::sqrt(rough_hand_[ju]) / std::sqrt(6.0);
    double a = 0.0;  // |second difference| now, when the joint was seen in the two frames before
    if (have2) a = (xn - 2.0 * load(x1) + load(x2)).norm();
    // The radius opens to this frame's own second difference so that a one-frame outlier
    // is taken back whole; in the hand's frame, so that a hand that sweeps, stops or turns
    // as a whole is not held back by it (a Leap swipe stopping within a 30 Hz row: the
    // world's second difference let the network's overshoot through).
    double a_hand = refit ? 0.0 : a;
    if (have2 && !measured && !refit) {
      if (hand_frame < 0) hand_frame = hand_motion(x_back(2), x_back(1), x_now, from2, from1) ? 1 : 0;
      if (hand_frame > 0) a_hand = hand_second_difference(xn, load(x1), load(x2), from1, from2);
    }
    // Both roughnesses take this row's second difference after the radius is set (it does
    // not yet count as noise); the hand's is the world's where no hand motion was found.
    if (have2 && !refit_noise) {
      const double w = running_weight(count_[ju], kCorrectionRoughnessFrames);
      rough_[ju] += w * (a * a - rough_[ju]);
      rough_hand_[ju] += w * (a_hand * a_hand - rough_hand_[ju]);
    }
    // Nor to InputNoise's jump on a re-fit's own row that is followed (refit_share()).
    // A joint still off its bones (InputNoise::stretched) after a jump against its hand is
    // an outlier that lasts: its second difference is back to nothing (shifted now and the
    // row before alike), and the radius opens to the row before's jump. A re-fit that
    // stays looks the same to the second differences but keeps its bones.
    const bool off_bones = have_stretched && stretched[ju];
    const double r = std::max(noise_r, measured ? (refit ? 0.0 : jump[ju]) : std::max(a_hand, off_bones ? jump_before : 0.0));
    radius_[ju] = r;
    float* dj = path.data() + o;
    if (!finite_xyz(dj)) continue;
    const Eigen::Vector3d d = load(dj);
    // The denoised frame: less the network's mean offset from its input (noise averages out
    // of a correction, a bias does not; each step at most the noise radius, so an outlier's
    // one large correction does not become an offset; applied only where it stands out of
    // its own standard error); on a row that is no jump, the correction shrunk to the share
    // the noise explains, E|n|^2 read from the correction's own correlation over frames and,
    // where the noise is measured at the input rate, at most twice that (a jump's
    // correction is the outlier taken back, and stays out of the mean); pulled into the
    // ball around x.
    mean_step(bias_[ju], spread_[ju], last_[ju], bias_count_[ju], d - xn, noise_r);
    Eigen::Vector3d c = d - significant(bias_[ju], spread_[ju], bias_count_[ju]) - xn;
    if (!(r > noise_r) && c.allFinite()) {
      const double from_c = correlated_noise2(ju, c);
      c *= explained_share(corr2_[ju], measured ? std::min(from_c, kCorrectionShareFactor * noise2[ju]) : from_c);
    }
    cs[ju] = c;
    s_of[ju] = s;
    a_of[ju] = a;
    nr_of[ju] = noise_r;
    // The radius for the joint's own correction. The world's where the hand-frame noise is
    // over kMeasuredNoiseMaxRms, as for measured noise over it (a heavy tail of shifts, the
    // `paper` preset's, reads ~10 mm RMS and takes 50 mm shifts back: three RMS of it,
    // without the hand's motion in it, held them millimetres short), and where the joint
    // has no second difference this row (back from a gap: nothing says what it did
    // against its hand; on FPHA `paper`, with its occlusions, most of what was left held),
    // and where its bones are off their length (an outlier: no motion with the hand).
    rh_of[ju] = measured || !have2 || off_bones || noise_rh > kCorrectionNoiseFactor * kMeasuredNoiseMaxRms
                    ? r
                    : std::max(noise_rh, a_hand);
    if (!measured && have2 && a_hand > noise_rh) hand_jump_[ju] = a_hand;
  }
  // The radius in the hand's frame bounds what a joint is moved against its hand; the whole
  // hand's correction (the median over joints of theirs, each axis: an outlier taken back
  // does not move it) keeps the world's radius, which a hand's motion, or a tremor of the
  // whole hand the network removes, opens. A hand that sweeps at 30 Hz has centimetres of
  // second difference at every joint, which in the world let the network's errors of a
  // joint's own through by millimetres (docs/STGAE.md "The roughness in the hand's frame").
  const Eigen::Vector3d m = whole_hand_share(cs, radius_, nr_of);
  for (int j = 0; j < kJointCount; ++j) {
    const auto ju = static_cast<size_t>(j);
    const size_t o = 3 * ju;
    if (!cs[ju].allFinite()) continue;
    const Eigen::Vector3d xn = load(x_now + o);
    float* dj = path.data() + o;
    const Eigen::Vector3d d = load(dj);
    const float* x1 = n_ >= 1 ? x_back(1) + o : nullptr;
    const bool have1 = x1 && finite_xyz(x1);
    const double s = s_of[ju], a = a_of[ju], noise_r = nr_of[ju], r = radius_[ju];
    Eigen::Vector3d c = cs[ju];
    const Eigen::Vector3d o0 = Eigen::Vector3d::Zero();
    if (rh_of[ju] < r) c = clamp_into(m, o0, r) + clamp_into(Eigen::Vector3d(c - m), o0, rh_of[ju]);
    const Eigen::Vector3d den = clamp_into(Eigen::Vector3d(xn + c), xn, r);
    store(den, dj);
    den_back(0, ju) = den;
    // This row says where the displacements made before went, unless it is an outlier of
    // the stream's own frames. Not InputNoise's jumps, even where the noise is measured: a
    // fast hand's rows leave their quadratic by more than the noise (on rows slower than
    // the model most of a swipe's), and those are the rows the predictions must learn from.
    const bool evidence = !(a > kCorrectionNoiseFactor * s);
    // Predicted frame f: the network's displacement less its mean excess over what the
    // input did in f frames, then within reach of constant velocity from the denoised
    // frame: one RMS of the velocity's noise (s / sqrt(3) per period) and of the recent
    // accelerations (s per period^2), plus f times this frame's jump (an outlier now
    // throws the velocity off by that much).
    const Eigen::Vector3d v = have1 ? Eigen::Vector3d(xn - load(x1)) : Eigen::Vector3d::Zero();
    // The denoised frames' mean step over the last kPredictionBlendStepFrames (NaN: none
    // that far back), the velocity forecast's.
    constexpr long kStep = kPredictionBlendStepFrames;
    const Eigen::Vector3d den_step = n_ >= kStep ? Eigen::Vector3d((den - den_back(kStep, ju)) / kStep) : none();
    for (size_t f = 1; f < F; ++f) {
      float* pf = path.data() + f * kFs + o;
      if (!finite_xyz(pf)) continue;
      const Eigen::Vector3d disp = load(pf) - d;
      const size_t b = f * kJointCount + ju;
      store(disp, disp_now + (f - 1) * kFs + o);
      const auto back = static_cast<long>(f);
      if (n_ >= back) {  // the displacement predicted f frames ago, against the input's since
        const float* then = x_back(back) + o;
        const float* said = disp_.data() + ring(back) * (F - 1) * kFs + (f - 1) * kFs + o;
        if (finite_xyz(then) && finite_xyz(said))
          mean_step(bias_[b], spread_[b], last_[b], bias_count_[b], load(said) - (xn - load(then)), noise_r);
      }
      const double fd = static_cast<double>(f);
      const double reach = s * (fd / std::sqrt(3.0) + 0.5 * fd * fd) + fd * a;
      // Where the input went since the denoised frame f frames ago (NaN: no frame then, or
      // this row is a jump): what the gain and the blend read their predictions against.
      const Eigen::Vector3d went = evidence && n_ >= back ? Eigen::Vector3d(xn - den_back(back, ju)) : none();
      const Eigen::Vector3d g = gained(f, ju, disp - significant(bias_[b], spread_[b], bias_count_[b]), went, gain_from);
      const Eigen::Vector3d e = blended(f, ju, g, fd * den_step, went);
      store(clamp_into(den + e, den + fd * v, reach), pf);
    }
  }
  for (size_t f = 1; f < F; ++f) {
    if (!(row_den_[f] > 0.0)) continue;  // no pair came of age on this row
    const double w = running_weight(blend_count_[f], kPredictionBlendFrames);
    blend_num_[f] += w * (row_num_[f] - blend_num_[f]);
    blend_den_[f] += w * (row_den_[f] - blend_den_[f]);
  }
  ++n_;
}

}  // namespace hs
