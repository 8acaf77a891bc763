#include "handsteady/palm_fit.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace hs {

namespace {

using V3 = Eigen::Vector3d;

struct Rigid {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  V3 t = V3::Zero();
  double s = 1.0;
  V3 apply(const V3& p) const { return s * (r * p) + t; }
  V3 invert(const V3& q) const { return r.transpose() * (q - t) / s; }
};


// The rotation and translation taking the template points a to the row's points b (least
// squares over the points with use[i], Kabsch). False when they do not fix a rotation.
template <size_t P>
bool kabsch(const std::array<V3, P>& a, const std::array<V3, P>& b, const std::array<bool, P>& use, Rigid& out) {
  V3 ca = V3::Zero(), cb = V3::Zero();
  int n = 0;
  for (size_t i = 0; i < P; ++i)
    if (use[i]) {
      ca += a[i];
      cb += b[i];
      ++n;
    }
  if (n < 3) return false;
  ca /= n;
  cb /= n;
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < P; ++i)
    if (use[i]) h += (a[i] - ca) * (b[i] - cb).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  if (!(sv(1) > 1e-9 * std::max(sv(0), 1e-30))) return false;  // collinear points
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) d(2, 2) = -1.0;
  out.r = svd.matrixV() * d * svd.matrixU().transpose();
  // Uniform scale (Umeyama): trackers that re-estimate the hand's size as they go (Leap
  // Motion does, by up to 10 % between takes and 3 % within one) stay fitted.
  double va = 0.0;
  for (size_t i = 0; i < P; ++i)
    if (use[i]) va += (a[i] - ca).squaredNorm();
  const double tr = sv(0) * d(0, 0) + sv(1) * d(1, 1) + sv(2) * d(2, 2);
  out.s = va > 0.0 && tr > 0.0 ? tr / va : 1.0;
  out.t = cb - out.s * (out.r * ca);
  return true;
}

}  // namespace

void PalmFit::reset() noexcept {
  for (auto& p : tmpl_) p = {0.0, 0.0, 0.0};
  count_.fill(0.0);
  rows_ = 0;
  resid2_ = resid_rows_ = 0.0;
  resid_.fill(0.0);
  resid_n_.fill(0.0);
}

void PalmFit::apply(Pose& pose) noexcept {
  std::array<V3, kP> b, a;
  std::array<bool, kP> have{}, known{}, use{};
  int n_have = 0, n_use = 0;
  for (size_t i = 0; i < kP; ++i) {
    const int j = kPalmJoints[i];
    b[i] = pose.row(j).transpose();
    have[i] = b[i].allFinite();
    n_have += have[i];
    a[i] = V3(tmpl_[i][0], tmpl_[i][1], tmpl_[i][2]);
    known[i] = count_[i] > 0.0;
    use[i] = have[i] && known[i];
    n_use += use[i];
  }
  if (n_have < kPalmMinPoints) return;
  if (rows_ == 0) {  // the first row sets the template
    for (size_t i = 0; i < kP; ++i)
      if (have[i]) {
        tmpl_[i] = {b[i].x(), b[i].y(), b[i].z()};
        count_[i] = 1.0;
      }
    rows_ = 1;
    return;
  }
  if (n_use < kPalmMinPoints) return;
  // Joints that do not move with the palm in this tracker (their running residual far
  // above the others') are neither fitted nor answered: they pass through.
  std::array<double, kP> sorted{};
  int n_r = 0;
  for (size_t i = 0; i < kP; ++i)
    if (known[i] && resid_n_[i] > 0.0) sorted[static_cast<size_t>(n_r++)] = resid_[i];
  double typical = 0.0;
  if (n_r > 0) {
    std::nth_element(sorted.begin(), sorted.begin() + n_r / 2, sorted.begin() + n_r);
    typical = sorted[static_cast<size_t>(n_r / 2)];
  }
  std::array<bool, kP> rigid{};
  for (size_t i = 0; i < kP; ++i)
    rigid[i] = known[i] && !(resid_n_[i] >= kPalmMinRows &&
                             resid_[i] > kPalmRigidFactor * typical + kPalmRigidFloorM * kPalmRigidFloorM);
  n_use = 0;
  for (size_t i = 0; i < kP; ++i) {
    use[i] = use[i] && rigid[i];
    n_use += use[i];
  }
  if (n_use < kPalmMinPoints) return;
  // Joints far off the fit leave it one at a time, the worst first, and the rest are
  // refitted (robust to a few joints that jumped: one 30 mm jump pulls a least-squares fit
  // of 11 points by ~3 mm, so a single cut after one fit would drop good joints too).
  const double scale = resid_rows_ >= 1.0 ? std::sqrt(resid2_) : std::numeric_limits<double>::infinity();
  const double cut = std::max(kPalmOutlier * scale, kPalmOutlierFloorM);
  Rigid fit;
  int n_in = n_use;
  for (int round = 0;; ++round) {
    if (!kabsch(a, b, use, fit)) return;
    size_t worst = kP;
    double worst2 = cut * cut;
    for (size_t i = 0; i < kP; ++i)
      if (use[i]) {
        const double e2 = (fit.apply(a[i]) - b[i]).squaredNorm();
        if (e2 > worst2) {
          worst2 = e2;
          worst = i;
        }
      }
    if (worst == kP) break;
    if (round == kPalmMaxOutliers || n_in <= kPalmMinPoints) return;  // too many disagree: no fit this row
    use[worst] = false;
    --n_in;
  }
  // Learn: the inliers (and joints the template does not know yet) in the template's frame;
  // every present joint's residual (winsorised at the cut, so one jump does not make a
  // joint non-rigid).
  double rs = 0.0;
  for (size_t i = 0; i < kP; ++i) {
    if (!have[i]) continue;
    if (known[i]) {
      const double e2 = std::min((fit.apply(a[i]) - b[i]).squaredNorm(), cut * cut);
      resid_n_[i] = std::min(resid_n_[i] + 1.0, kPalmTemplateRows);
      resid_[i] += (e2 - resid_[i]) / resid_n_[i];
      if (use[i]) rs += e2;
    }
    if (known[i] && !use[i] && rigid[i]) continue;  // an outlier this row
    const V3 local = fit.invert(b[i]);
    count_[i] = std::min(count_[i] + 1.0, kPalmTemplateRows);
    for (int k = 0; k < 3; ++k) tmpl_[i][static_cast<size_t>(k)] += (local(k) - tmpl_[i][static_cast<size_t>(k)]) / count_[i];
  }
  resid_rows_ = std::min(resid_rows_ + 1.0, kPalmTemplateRows);
  resid2_ += (rs / n_in - resid2_) / resid_rows_;
  ++rows_;
  if (rows_ <= kPalmMinRows) return;
  // Answer: every rigid palm joint the template knows, where the fit puts it.
  for (size_t i = 0; i < kP; ++i) {
    if (!rigid[i]) continue;
    const V3 p = fit.apply(a[i]);
    pose.row(kPalmJoints[i]) = p.transpose();
  }
}

}  // namespace hs
