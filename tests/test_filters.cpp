// Classical filters: analytic responses (step, ramp, sine), robustness to bad input,
// missing joints and gaps, reset, and no heap allocation in push/estimate.
#include "handsteady/filters.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"

#include "allocation_counting.hpp"
#include "test_support.hpp"

#include <array>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>


namespace {

using hs::FilterConfig;
using hs::FilterMethod;
using hs::kJointCount;
using hs::Pose;
using Vec3 = Eigen::Vector3d;

using hs::kNaN;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = std::numbers::pi;
// The classical methods (Multi-STGAE has its own tests: test_stgae_engine, test_correction_bound).
const std::array<FilterMethod, 4> kMethods = {FilterMethod::Raw, FilterMethod::OneEuro, FilterMethod::Desp,
                                              FilterMethod::Kalman};

FilterConfig config(FilterMethod m) {
  FilterConfig c;
  c.method = m;
  return c;
}

// Every joint at x + j * (1 mm, 2 mm, 3 mm) so joints are distinguishable.
Pose pose_at(const Vec3& x) {
  Pose p;
  for (int j = 0; j < kJointCount; ++j) p.row(j) = (x + 1e-3 * j * Vec3(1, 2, 3)).transpose();
  return p;
}

Pose estimate(const hs::PoseFilter& f, double t) {
  Pose out;
  f.estimate(t, out);
  return out;
}

// Bitwise equality, NaN matching NaN.
template <class A, class B>
bool same_pose(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
  for (Eigen::Index j = 0; j < a.rows(); ++j) {
    for (Eigen::Index k = 0; k < a.cols(); ++k) {
      const bool both_nan = std::isnan(a(j, k)) && std::isnan(b(j, k));
      if (!both_nan && a(j, k) != b(j, k)) return false;
    }
  }
  return true;
}

// A smooth, noisy 3D motion sampled at 30 Hz.
struct Motion {
  std::vector<double> t;
  std::vector<Pose> pos;
};
Motion noisy_motion(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.003);
  Motion m;
  for (int i = 0; i < n; ++i) {
    const double t = i / 30.0;
    const Vec3 x(0.1 * std::sin(2 * kPi * 0.5 * t), 0.08 * std::sin(2 * kPi * 0.7 * t + 0.3), 0.05 * std::cos(t));
    Pose p = pose_at(x);
    for (int j = 0; j < kJointCount; ++j) p.row(j) += Eigen::RowVector3d(noise(rng), noise(rng), noise(rng));
    m.t.push_back(t);
    m.pos.push_back(p);
  }
  return m;
}

}  // namespace

TEST_CASE("method names round-trip, unknown names and bad parameters are rejected") {
  for (FilterMethod m : hs::kFilterMethods) CHECK(hs::parse_filter_method(hs::filter_method_name(m)) == m);
  CHECK(hs::parse_filter_method("stgae") == FilterMethod::Stgae);
  CHECK_THROWS_AS(hs::parse_filter_method("one-euro"), std::invalid_argument);
  CHECK_THROWS_AS(hs::parse_filter_method(""), std::invalid_argument);

  FilterConfig c = config(FilterMethod::OneEuro);
  c.oneeuro.min_cutoff_hz = 0.0;
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);
  c = config(FilterMethod::OneEuro);
  c.oneeuro.beta = -1.0;
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);
  c = config(FilterMethod::Desp);
  c.desp.alpha = 1.0;
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);
  c.desp.alpha = 0.5;
  c.desp.period_s = -0.01;
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);
  c = config(FilterMethod::Kalman);
  c.kalman.meas_sd_m = 0.0;
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);
  c = config(FilterMethod::Raw);
  c.max_gap_s = kNaN;
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);

  CHECK(hs::filter_params_summary(config(FilterMethod::Raw)) == "max_gap_ms=500");
  c = config(FilterMethod::Desp);
  c.desp.alpha = 0.25;
  c.desp.period_s = 0.02;
  CHECK(hs::filter_params_summary(c) == "alpha=0.25 period_ms=20 max_gap_ms=500");
}

TEST_CASE("before any input every joint is NaN and last_time is NaN") {
  for (FilterMethod m : kMethods) {
    auto f = hs::make_filter(config(m));
    CHECK(std::isnan(f->last_time()));
    CHECK(estimate(*f, 1.0).array().isNaN().all());
  }
}

TEST_CASE("raw holds the last observation of each joint, whatever the requested time") {
  auto f = hs::make_filter(config(FilterMethod::Raw));
  const Pose a = pose_at(Vec3(0.1, 0.2, 0.3));
  Pose b = pose_at(Vec3(0.4, 0.5, 0.6));
  b.row(7).setConstant(kNaN);
  REQUIRE(f->push(0.0, a));
  REQUIRE(f->push(0.1, b));
  const Pose out = estimate(*f, 0.3);
  CHECK(out.row(7) == a.row(7));
  CHECK(out.row(0) == b.row(0));
  CHECK(out.row(25) == b.row(25));
}

TEST_CASE("One Euro with beta = 0: step response is the first-order low-pass closed form") {
  FilterConfig c = config(FilterMethod::OneEuro);
  c.oneeuro.min_cutoff_hz = 2.0;
  c.oneeuro.beta = 0.0;
  for (bool vec3 : {true, false}) {
    c.oneeuro.vec3 = vec3;
    auto f = hs::make_filter(c);
    const double te = 1.0 / 30.0;
    const double a = 1.0 / (1.0 + 1.0 / (2 * kPi * 2.0 * te));  // alpha per step
    REQUIRE(f->push(0.0, pose_at(Vec3::Zero())));
    CHECK(estimate(*f, 0.0).row(0).norm() == 0.0);
    for (int n = 1; n <= 60; ++n) {
      REQUIRE(f->push(n * te, pose_at(Vec3(1.0, -2.0, 0.5))));
      const double expected = 1.0 - std::pow(1.0 - a, n);  // x_n = 1 - (1 - a)^n per unit step
      const Pose out = estimate(*f, n * te);
      CHECK(out(0, 0) == doctest::Approx(expected).epsilon(1e-12));
      CHECK(out(0, 1) == doctest::Approx(-2.0 * expected).epsilon(1e-12));
      CHECK(out(0, 2) == doctest::Approx(0.5 * expected).epsilon(1e-12));
      // Non-predicting: later requests return the same value.
      CHECK(same_pose(estimate(*f, n * te + 0.05), out));
    }
  }
}

TEST_CASE("One Euro with beta = 0: ramp lag is 1 / (2 pi mincutoff)") {
  for (double fc : {0.5, 1.0, 3.0}) {
    FilterConfig c = config(FilterMethod::OneEuro);
    c.oneeuro.min_cutoff_hz = fc;
    c.oneeuro.beta = 0.0;
    auto f = hs::make_filter(c);
    const double te = 1.0 / 90.0;
    const Vec3 v(0.3, -0.1, 0.2);  // m/s
    double t = 0.0;
    for (int n = 0; n < 2000; ++n) {
      t = n * te;
      REQUIRE(f->push(t, pose_at(v * t)));
    }
    const Vec3 lagged = estimate(*f, t).row(3).transpose() - 3e-3 * Vec3(1, 2, 3);
    const double lag_s = (v * t - lagged).norm() / v.norm();
    CHECK(lag_s == doctest::Approx(1.0 / (2 * kPi * fc)).epsilon(1e-6));
  }
}

TEST_CASE("One Euro with beta > 0: ramp lag follows the speed-adapted cutoff") {
  // The derivative is taken against the previous filtered value, so on a ramp of speed v
  // with lag L it settles at v (1 + L / Te); the lag then satisfies
  // L = 1 / (2 pi (mincutoff + beta v (1 + L / Te))).
  const double te = 1.0 / 30.0, v = 0.2, mc = 1.0, beta = 5.0;
  double lag = 0.1;
  for (int i = 0; i < 200; ++i) lag = 1.0 / (2 * kPi * (mc + beta * v * (1 + lag / te)));
  FilterConfig c = config(FilterMethod::OneEuro);
  c.oneeuro.min_cutoff_hz = mc;
  c.oneeuro.beta = beta;
  c.oneeuro.vec3 = true;
  auto f = hs::make_filter(c);
  double t = 0.0;
  for (int n = 0; n < 600; ++n) {
    t = n * te;
    REQUIRE(f->push(t, pose_at(Vec3(0.0, v * t, 0.0))));
  }
  const double measured = (v * t - (estimate(*f, t)(0, 1))) / v;
  CHECK(measured == doctest::Approx(lag).epsilon(1e-6));
  CHECK(measured < 1.0 / (2 * kPi * mc));
}

TEST_CASE("One Euro with beta = 0: sine attenuation of a first-order low-pass") {
  const double fs = 100.0, te = 1.0 / fs, fc = 1.0;
  for (double freq : {0.5, 1.0, 3.0}) {
    FilterConfig c = config(FilterMethod::OneEuro);
    c.oneeuro.min_cutoff_hz = fc;
    c.oneeuro.beta = 0.0;
    auto f = hs::make_filter(c);
    const double w = 2 * kPi * freq * te;  // radians per sample
    const int settle = 2000, n_fit = static_cast<int>(std::lround(10.0 * fs));  // 10 s: whole periods
    double cs = 0.0, cc = 0.0;
    for (int n = 0; n < settle + n_fit; ++n) {
      REQUIRE(f->push(n * te, pose_at(Vec3(std::sin(w * n), 0.0, 0.0))));
      if (n >= settle) {
        const double y = estimate(*f, n * te)(0, 0);
        cs += y * std::sin(w * n);
        cc += y * std::cos(w * n);
      }
    }
    const double gain = 2.0 / n_fit * std::hypot(cs, cc);
    // Exact gain of y_n = a x_n + (1 - a) y_{n-1}, and the continuous first-order gain.
    const double a = 1.0 / (1.0 + 1.0 / (2 * kPi * fc * te));
    const double discrete = std::abs(a / (1.0 - (1.0 - a) * std::polar(1.0, -w)));
    const double continuous = 1.0 / std::sqrt(1.0 + (freq / fc) * (freq / fc));
    CHECK(gain == doctest::Approx(discrete).epsilon(1e-6));
    CHECK(gain == doctest::Approx(continuous).epsilon(0.03));
  }
}

TEST_CASE("DESP: the steady-state prediction on a ramp is exact at any horizon") {
  for (double period : {0.0, 1.0 / 30.0}) {
    for (double alpha : {0.2, 0.5, 0.8}) {
      FilterConfig c = config(FilterMethod::Desp);
      c.desp.alpha = alpha;
      c.desp.period_s = period;
      auto f = hs::make_filter(c);
      const Vec3 v(0.5, -0.25, 0.1);
      double t = 0.0;
      for (int n = 0; n < 300; ++n) {
        t = n / 30.0;
        REQUIRE(f->push(t, pose_at(v * t)));
      }
      for (double h : {0.0, 0.01, 1.0 / 30.0, 0.05, 0.2}) {
        const Pose out = estimate(*f, t + h);
        CHECK((out - pose_at(v * (t + h))).cwiseAbs().maxCoeff() < 1e-9);
      }
    }
  }
}

TEST_CASE("DESP on a constant signal predicts the constant, first sample is its own prediction") {
  auto f = hs::make_filter(config(FilterMethod::Desp));
  const Pose p = pose_at(Vec3(0.1, 0.2, 0.3));
  REQUIRE(f->push(5.0, p));
  CHECK(same_pose(estimate(*f, 5.5), p));
  REQUIRE(f->push(5.03, p));
  CHECK((estimate(*f, 5.2) - p).cwiseAbs().maxCoeff() < 1e-15);
}

TEST_CASE("Kalman on a noiseless ramp converges to the exact prediction") {
  for (double q : {0.1, 1.0, 10.0}) {
    FilterConfig c = config(FilterMethod::Kalman);
    c.kalman.accel_psd = q;
    auto f = hs::make_filter(c);
    const Vec3 v(0.4, 0.1, -0.3);
    double err_early = 0.0, err_late = 0.0, t = 0.0;
    for (int n = 0; n < 600; ++n) {
      t = n / 30.0;
      REQUIRE(f->push(t, pose_at(v * t)));
      const double err = (estimate(*f, t + 0.05) - pose_at(v * (t + 0.05))).cwiseAbs().maxCoeff();
      if (n == 0) err_early = err;
      err_late = err;
    }
    CHECK(err_early > 1e-2);  // the velocity starts at zero: the test can see convergence
    CHECK(err_late < 1e-9);
  }
}

TEST_CASE("Kalman matches the textbook matrix recursion at irregular time steps") {
  FilterConfig c = config(FilterMethod::Kalman);
  c.kalman = {0.004, 2.5, 0.7};
  auto f = hs::make_filter(c);
  const std::array<double, 5> t = {0.0, 0.03, 0.08, 0.09, 0.15};
  const std::array<double, 5> z = {0.10, 0.12, 0.11, 0.16, 0.20};
  Eigen::Vector2d x(z[0], 0.0);
  Eigen::Matrix2d P = Eigen::Vector2d(0.004 * 0.004, 0.7 * 0.7).asDiagonal();
  REQUIRE(f->push(t[0], pose_at(Vec3(z[0], 0.0, 0.0))));
  for (size_t i = 1; i < t.size(); ++i) {
    const double dt = t[i] - t[i - 1];
    Eigen::Matrix2d F;
    F << 1, dt, 0, 1;
    Eigen::Matrix2d Q;
    Q << dt * dt * dt / 3, dt * dt / 2, dt * dt / 2, dt;
    Q *= 2.5;
    x = F * x;
    P = F * P * F.transpose() + Q;
    const Eigen::RowVector2d H(1, 0);
    const double S = (H * P * H.transpose())(0, 0) + 0.004 * 0.004;
    const Eigen::Vector2d K = P * H.transpose() / S;
    x += K * (z[i] - x(0));
    P = (Eigen::Matrix2d::Identity() - K * H) * P;
    REQUIRE(f->push(t[i], pose_at(Vec3(z[i], 0.0, 0.0))));
    for (double h : {0.0, 0.02, 0.1}) {
      CHECK(estimate(*f, t[i] + h)(0, 0) == doctest::Approx(x(0) + h * x(1)).epsilon(1e-12));
    }
  }
}

TEST_CASE("DESP with irregular input: alpha per sample, tau in mean observed periods") {
  const double a = 0.4;
  FilterConfig c = config(FilterMethod::Desp);
  c.desp.alpha = a;
  auto f = hs::make_filter(c);
  const std::array<double, 3> t = {1.0, 1.03, 1.10};
  const std::array<double, 3> p = {0.2, 0.25, 0.4};
  double S = p[0], S2 = p[0];
  REQUIRE(f->push(t[0], pose_at(Vec3(0.0, 0.0, p[0]))));
  for (size_t i = 1; i < t.size(); ++i) {
    S = a * p[i] + (1 - a) * S;
    S2 = a * S + (1 - a) * S2;
    REQUIRE(f->push(t[i], pose_at(Vec3(0.0, 0.0, p[i]))));
    const double period = (t[i] - t[0]) / static_cast<double>(i);  // running mean
    for (double h : {0.0, 0.02, 0.07}) {
      const double k = a * (h / period) / (1 - a);
      CHECK(estimate(*f, t[i] + h)(0, 2) == doctest::Approx((2 + k) * S - (1 + k) * S2).epsilon(1e-12));
    }
  }
  // A fixed nominal period overrides the observed one.
  c.desp.period_s = 0.01;
  auto g = hs::make_filter(c);
  for (size_t i = 0; i < t.size(); ++i) REQUIRE(g->push(t[i], pose_at(Vec3(0.0, 0.0, p[i]))));
  const double k = a * (0.05 / 0.01) / (1 - a);
  CHECK(estimate(*g, t[2] + 0.05)(0, 2) == doctest::Approx((2 + k) * S - (1 + k) * S2).epsilon(1e-12));
}

TEST_CASE("Kalman: first observation is the estimate, with zero velocity") {
  auto f = hs::make_filter(config(FilterMethod::Kalman));
  const Pose p = pose_at(Vec3(-0.1, 0.0, 0.2));
  REQUIRE(f->push(1.0, p));
  CHECK(same_pose(estimate(*f, 1.3), p));
}

TEST_CASE("predictions request earlier than the last input are answered at the last input") {
  const Motion m = noisy_motion(20, 3);
  for (FilterMethod method : kMethods) {
    auto f = hs::make_filter(config(method));
    for (size_t i = 0; i < m.t.size(); ++i) REQUIRE(f->push(m.t[i], m.pos[i]));
    const double last = m.t.back();
    CHECK(f->last_time() == last);
    CHECK(same_pose(estimate(*f, last - 0.5), estimate(*f, last)));
    CHECK(same_pose(estimate(*f, kNaN), estimate(*f, last)));
    CHECK(same_pose(estimate(*f, kInf), estimate(*f, last)));
  }
}

TEST_CASE("repeated, backward and non-finite timestamps are rejected without touching the state") {
  const Motion m = noisy_motion(40, 5);
  for (FilterMethod method : kMethods) {
    auto clean = hs::make_filter(config(method));
    auto dirty = hs::make_filter(config(method));
    const Pose junk = pose_at(Vec3(5.0, -5.0, 5.0));
    for (size_t i = 0; i < m.t.size(); ++i) {
      REQUIRE(clean->push(m.t[i], m.pos[i]));
      REQUIRE(dirty->push(m.t[i], m.pos[i]));
      CHECK_FALSE(dirty->push(m.t[i], junk));          // repeated
      CHECK_FALSE(dirty->push(m.t[i] - 0.01, junk));   // backward
      CHECK_FALSE(dirty->push(kNaN, junk));
      CHECK_FALSE(dirty->push(kInf, junk));
      CHECK_FALSE(dirty->push(-kInf, junk));
      CHECK(dirty->last_time() == m.t[i]);
      CHECK(same_pose(estimate(*dirty, m.t[i] + 0.02), estimate(*clean, m.t[i] + 0.02)));
    }
  }
}

TEST_CASE("NaN and inf coordinates count as a missing joint and never reach the state") {
  const Motion m = noisy_motion(40, 7);
  for (FilterMethod method : kMethods) {
    auto clean = hs::make_filter(config(method));  // sees NaN rows where the dirty one sees junk
    auto dirty = hs::make_filter(config(method));
    for (size_t i = 0; i < m.t.size(); ++i) {
      Pose c = m.pos[i], d = m.pos[i];
      if (i % 3 == 1) {
        c.row(4).setConstant(kNaN);
        d(4, 1) = kInf;  // one bad coordinate poisons the whole joint
        c.row(9).setConstant(kNaN);
        d(9, 2) = kNaN;
        c.row(12).setConstant(kNaN);
        d.row(12).setConstant(-kInf);
      }
      REQUIRE(clean->push(m.t[i], c));
      REQUIRE(dirty->push(m.t[i], d));
      const Pose out = estimate(*dirty, m.t[i] + 0.03);
      CHECK(out.allFinite());
      CHECK(same_pose(out, estimate(*clean, m.t[i] + 0.03)));
    }
  }
}

TEST_CASE("a joint missing for some frames keeps its state and resumes with the real time step") {
  // The reference filter sees the joint only at the frames where it is present, so its
  // per-joint time steps are the same; the other joints are unaffected by the gap.
  const Motion m = noisy_motion(60, 11);
  for (FilterMethod method : kMethods) {
    FilterConfig c = config(method);
    c.desp.period_s = 1.0 / 30.0;  // the auto period would differ with fewer frames
    auto with_gap = hs::make_filter(c);
    auto reference = hs::make_filter(c);
    auto no_gap = hs::make_filter(c);
    for (size_t i = 0; i < m.t.size(); ++i) {
      const bool missing = i >= 20 && i < 26;
      Pose p = m.pos[i];
      if (missing) p.row(6).setConstant(kNaN);
      REQUIRE(with_gap->push(m.t[i], p));
      REQUIRE(no_gap->push(m.t[i], m.pos[i]));
      if (!missing) REQUIRE(reference->push(m.t[i], m.pos[i]));
      const Pose out = estimate(*with_gap, m.t[i] + 0.02);
      const Pose ref = estimate(*reference, m.t[i] + 0.02);
      const Pose full = estimate(*no_gap, m.t[i] + 0.02);
      CHECK(same_pose(out.row(6), ref.row(6)));  // predicted through the gap from the last observation
      CHECK(same_pose(out.row(5), full.row(5)));
      if (missing) CHECK(out.row(6).allFinite());
    }
  }
}

TEST_CASE("a joint unseen for longer than max_gap expires, then re-initialises") {
  for (FilterMethod method : kMethods) {
    FilterConfig c = config(method);
    c.max_gap_s = 0.21;  // not on a frame boundary
    auto f = hs::make_filter(c);
    double t = 0.0;
    for (int n = 0; n < 30; ++n) {
      t = n / 30.0;
      REQUIRE(f->push(t, pose_at(Vec3(0.3 * t, 0.0, 0.0))));
    }
    const double t_seen = t;
    Pose hole = pose_at(Vec3::Zero());
    hole.row(2).setConstant(kNaN);
    int n = 30;
    for (; (n / 30.0) - t_seen <= 0.21; ++n) {
      REQUIRE(f->push(n / 30.0, hole));
      CHECK(estimate(*f, n / 30.0).row(2).allFinite());
    }
    REQUIRE(f->push(n / 30.0, hole));  // now more than max_gap without joint 2
    CHECK(estimate(*f, n / 30.0).row(2).array().isNaN().all());
    CHECK(estimate(*f, n / 30.0).row(3).allFinite());
    // Reappearing: a fresh start (first sample = the observation, no memory of the motion).
    const Pose back = pose_at(Vec3(-1.0, 1.0, 2.0));
    REQUIRE(f->push((n + 1) / 30.0, back));
    CHECK((estimate(*f, (n + 1) / 30.0 + 0.05).row(2) - back.row(2)).cwiseAbs().maxCoeff() < 1e-15);
  }
}

TEST_CASE("reset() returns to the freshly constructed state") {
  const Motion a = noisy_motion(30, 13);
  const Motion b = noisy_motion(30, 17);
  for (FilterMethod method : kMethods) {
    auto used = hs::make_filter(config(method));
    auto fresh = hs::make_filter(config(method));
    for (size_t i = 0; i < a.t.size(); ++i) REQUIRE(used->push(a.t[i] + 100.0, a.pos[i]));
    used->reset();
    CHECK(std::isnan(used->last_time()));
    CHECK(estimate(*used, 0.0).array().isNaN().all());
    for (size_t i = 0; i < b.t.size(); ++i) {
      REQUIRE(used->push(b.t[i], b.pos[i]));  // earlier than before the reset: accepted
      REQUIRE(fresh->push(b.t[i], b.pos[i]));
      CHECK(same_pose(estimate(*used, b.t[i] + 0.04), estimate(*fresh, b.t[i] + 0.04)));
    }
  }
}

TEST_CASE("defaults reduce the error of a noisy hand-like motion") {
  // Light tuning check: the smoothers beat the raw input at the current time and the
  // predictors beat holding the raw input at a 50 ms horizon.
  const Motion m = noisy_motion(900, 19);
  auto truth = [](double t) {
    return pose_at(Vec3(0.1 * std::sin(2 * kPi * 0.5 * t), 0.08 * std::sin(2 * kPi * 0.7 * t + 0.3),
                        0.05 * std::cos(t)));
  };
  auto rmse = [&](FilterMethod method, double h) {
    auto f = hs::make_filter(config(method));
    double se = 0.0;
    long count = 0;
    for (size_t i = 0; i < m.t.size(); ++i) {
      REQUIRE(f->push(m.t[i], m.pos[i]));
      if (i < 30) continue;
      se += (estimate(*f, m.t[i] + h) - truth(m.t[i] + h)).squaredNorm();
      count += kJointCount;
    }
    return std::sqrt(se / static_cast<double>(count));
  };
  const double raw0 = rmse(FilterMethod::Raw, 0.0), raw50 = rmse(FilterMethod::Raw, 0.05);
  CHECK(rmse(FilterMethod::Desp, 0.0) < raw0);
  CHECK(rmse(FilterMethod::Kalman, 0.0) < raw0);
  CHECK(rmse(FilterMethod::Desp, 0.05) < raw50);
  CHECK(rmse(FilterMethod::Kalman, 0.05) < raw50);
  // One Euro trades lag for jitter; its error stays within a few raw noise levels.
  CHECK(rmse(FilterMethod::OneEuro, 0.0) < 4.0 * raw0);
}

TEST_CASE("filter_series: causal per row, untracked rows stay untracked") {
  const Motion m = noisy_motion(20, 23);
  hs::HandSeries s;
  s.t = m.t;
  s.pos = m.pos;
  s.pos[5] = hs::untracked_pose();
  s.pos[6].row(3).setConstant(kNaN);
  auto f = hs::make_filter(config(FilterMethod::Kalman));
  const hs::HandSeries out = hs::filter_series(*f, s, 0.03);
  REQUIRE(out.size() == s.size());
  CHECK(out.t == s.t);
  CHECK(out.pos[5].array().isNaN().all());
  CHECK(out.pos[6].row(3).allFinite());  // estimated from state
  // Row i equals a filter fed rows 0..i, asked at t_i + h.
  auto g = hs::make_filter(config(FilterMethod::Kalman));
  for (size_t i = 0; i < s.size(); ++i) {
    REQUIRE(g->push(s.t[i], s.pos[i]));
    if (i != 5) CHECK(same_pose(out.pos[i], estimate(*g, s.t[i] + 0.03)));
  }
}

TEST_CASE("filter_series skipping stale rows: one after motion is answered from the estimate, a still hand's rows are samples") {
  // A moving hand whose tracker answers row 10 again at row 11 (a stale answer, within the
  // layer's 10 um of float rounding), and rows 20..22 again at 21, 22 and 23 (it stops).
  const Motion m = noisy_motion(40, 29);
  hs::HandSeries s;
  s.t = m.t;
  s.pos = m.pos;
  s.pos[11] = s.pos[10];
  s.pos[11](4, 1) += 3e-6;
  for (size_t i = 21; i <= 23; ++i) s.pos[i] = s.pos[20];
  for (FilterMethod method : {FilterMethod::Kalman, FilterMethod::Desp}) {
    const std::string name(hs::filter_method_name(method));
    CAPTURE(name);
    auto f = hs::make_filter(config(method));
    const hs::HandSeries out = hs::filter_series(*f, s, 0.02, true);
    // Not asked (the default), every row is a sample: the same filter fed every row.
    auto d = hs::make_filter(config(method));
    const hs::HandSeries plain = hs::filter_series(*d, s, 0.02);
    auto every = hs::make_filter(config(method));
    for (size_t i = 0; i < s.size(); ++i) {
      REQUIRE(every->push(s.t[i], s.pos[i]));
      CHECK(same_pose(plain.pos[i], estimate(*every, s.t[i] + 0.02)));
    }
    CHECK((plain.pos[11] - out.pos[11]).norm() > 1e-4);
    // The same filter fed every row but 11 and 21 (the first repeat of each run).
    auto g = hs::make_filter(config(method));
    for (size_t i = 0; i < s.size(); ++i) {
      if (i != 11 && i != 21) REQUIRE(g->push(s.t[i], s.pos[i]));
      CHECK(same_pose(out.pos[i], estimate(*g, s.t[i] + 0.02)));
    }
    // Row 11's answer carries the motion on: it is not the stale pose.
    CHECK((out.pos[11] - s.pos[11]).norm() > 1e-3);
  }
  // A hand still from its first row: every row is a sample, the answer is the pose.
  hs::HandSeries still;
  for (int i = 0; i < 30; ++i) {
    still.t.push_back(i / 30.0);
    still.pos.push_back(pose_at(Vec3(0.1, 0.2, -0.3)));
  }
  auto k = hs::make_filter(config(FilterMethod::Kalman));
  const hs::HandSeries held = hs::filter_series(*k, still, 0.0, true);
  CHECK(k->last_time() == still.t.back());
  for (size_t i = 0; i < still.size(); ++i) CHECK((held.pos[i] - still.pos[i]).norm() < 1e-9);
}

TEST_CASE("push and estimate never allocate") {
  using hs::test::g_allocations, hs::test::g_counting;
  const Motion m = noisy_motion(1000, 29);
  // The counter itself works (so the zero below means something).
  g_allocations = 0;
  g_counting = true;
  std::vector<double>* probe = new std::vector<double>(10);
  g_counting = false;
  delete probe;
  REQUIRE(g_allocations.load() >= 1);

  for (const bool palm_fit : {false, true})  // also behind the palm fit and with the bone fit (palm_fit.hpp, bone_fit.hpp)
  for (FilterMethod method : kMethods) {
    FilterConfig c = config(method);
    c.oneeuro.extrapolate = true;
    c.palm_fit = palm_fit;
    c.bone_fit = palm_fit;
    auto f = hs::make_filter(c);
    Pose out;
    Pose holey = m.pos[0];
    holey.row(1).setConstant(kNaN);
    g_allocations = 0;
    g_counting = true;
    for (size_t i = 0; i < m.t.size(); ++i) {
      f->push(m.t[i], (i % 10 == 3) ? holey : m.pos[i]);
      f->push(m.t[i], m.pos[i]);  // rejected
      f->estimate(m.t[i] + 0.05, out);
    }
    f->reset();
    g_counting = false;
    CHECK_MESSAGE(g_allocations.load() == 0, hs::filter_method_name(method) << (palm_fit ? " with the palm and bone fits" : ""));
  }
}

TEST_CASE("Multi-STGAE is one more method of the same config: make_filter and filter_series_with build it, refuse what cannot run") {
  const auto dir = hs::test::models_dir();
  FilterConfig c = config(FilterMethod::Stgae);
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);  // no model
  c.stgae.model = hs::load_hsm(dir / "handsteady_xr26_causal.hsm");
  c.stgae.source = "causal.hsm";
  // A hand moving as noisy_motion does.
  const Motion m = noisy_motion(60, 3);
  hs::HandSeries s;
  s.t = m.t;
  for (const Pose& p : m.pos) s.pos.push_back(hs::test::synthetic_hand() + p);
  for (bool bounded : {true, false}) {
    c.stgae.bounded = bounded;
    // The same answers as the adapter built directly, with the bone fit behind it and the
    // palm fit in front (both on by default).
    const auto direct = hs::with_palm_fit(hs::with_bone_fit(hs::make_stgae_filter(c.stgae.model, 0.0, 0, bounded)));
    const hs::HandSeries a = hs::filter_series_with(c, s, 0.02), b = hs::filter_series(*direct, s, 0.02);
    REQUIRE(a.size() == b.size());
    for (size_t i = 0; i < a.size(); ++i) CHECK(same_pose(a.pos[i], b.pos[i]));
  }
  CHECK(hs::filter_params_summary(c) == "model=causal.hsm rate_hz=30 window=16 horizon_frames=3 padding=causal mode=streaming phases=auto unbounded palm_fit=1 bone_fit=1");
  c.stgae.phases = 5;
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);
  c.stgae.phases = 0;
  c.stgae.offline = true;  // window mode is not a streaming filter
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);
  c.stgae.offline = false;
  c.stgae.model = hs::load_hsm(dir / "handsteady_xr26_centred.hsm");  // a centred model cannot stream
  CHECK_THROWS_AS(hs::make_filter(c), std::invalid_argument);
  c.stgae.offline = true;
  const hs::HandSeries off = hs::filter_series_with(c, s, 0.0);
  REQUIRE(off.size() == s.size());
  CHECK(off.pos[30].allFinite());
  CHECK(hs::filter_params_summary(c).find("mode=offline") != std::string::npos);
  CHECK_THROWS_AS(hs::filter_series_with(c, s, -0.01), std::invalid_argument);
}
