// The time-series primitives: frame interpolation under each one-sided rule, the path
// reader's segments, the pose history's exact / interpolated / unanswered times.
#include "handsteady/time_series.hpp"

#include "test_support.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace {

using hs::kNaN;

}  // namespace

TEST_CASE("lerp_frame: both sides interpolate, one side follows the rule, neither side stays missing") {
  // Joint 0 in both, joint 1 only in a, joint 2 only in b, joint 3 in neither.
  const std::array<double, 12> a = {0, 0, 0, 1, 2, 3, kNaN, kNaN, kNaN, kNaN, kNaN, kNaN};
  const std::array<double, 12> b = {1, 2, 4, kNaN, kNaN, kNaN, 7, 8, 9, kNaN, kNaN, kNaN};
  std::array<float, 12> out{};
  const auto run = [&](double w, hs::OneSided rule) { hs::lerp_frame<double, float>(a, b, w, rule, out); };

  run(0.25, hs::OneSided::Drop);
  CHECK(out[0] == doctest::Approx(0.25));
  CHECK(out[2] == doctest::Approx(1.0));
  for (int i = 3; i < 12; ++i) CHECK(std::isnan(out[static_cast<size_t>(i)]));

  run(0.25, hs::OneSided::Nearer);  // a is nearer: joint 1 from a, joint 2 missing (a misses it)
  CHECK(out[3] == 1.0f);
  CHECK(std::isnan(out[6]));
  run(0.75, hs::OneSided::Nearer);  // b is nearer
  CHECK(std::isnan(out[3]));
  CHECK(out[6] == 7.0f);

  run(0.75, hs::OneSided::Either);
  CHECK(out[3] == 1.0f);
  CHECK(out[8] == 9.0f);
  CHECK(std::isnan(out[9]));
}

TEST_CASE("path_place: inside, before the first point and past the last point") {
  auto p = hs::path_place(1.25, 3);
  CHECK(p.seg == 1);
  CHECK(p.f == doctest::Approx(0.25));
  p = hs::path_place(-0.5, 3);  // the first segment continues backwards
  CHECK(p.seg == 0);
  CHECK(p.f == doctest::Approx(-0.5));
  p = hs::path_place(4.5, 3);  // the last segment continues
  CHECK(p.seg == 2);
  CHECK(p.f == doctest::Approx(2.5));
  CHECK(hs::lerp_value(1.0f, 3.0f, p.f) == doctest::Approx(6.0));
}

TEST_CASE("PoseHistory: exact at kept times, interpolated between them, nothing outside, ring keeps the newest") {
  hs::PoseHistory<4, int64_t> h;
  hs::Pose out = hs::untracked_pose();
  CHECK(h.at(0, out) == hs::TimeAnswer::None);
  for (int64_t k = 0; k < 6; ++k) {
    hs::Pose p = hs::Pose::Constant(static_cast<double>(k));
    if (k == 4) p.row(5).setConstant(kNaN);
    REQUIRE(h.push(10 * k, p));
  }
  CHECK_FALSE(h.push(50, hs::Pose::Zero()));  // not newer
  CHECK(h.size() == 4);
  CHECK(h.newest() == 50);
  // Kept: 20, 30, 40, 50.
  CHECK(h.at(10, out) == hs::TimeAnswer::None);
  CHECK(h.at(51, out) == hs::TimeAnswer::None);
  CHECK(h.at(30, out) == hs::TimeAnswer::Exact);
  CHECK(out(0, 0) == 3.0);
  CHECK(h.at(25, out) == hs::TimeAnswer::Interpolated);
  CHECK(out(0, 0) == doctest::Approx(2.5));
  CHECK(h.at(45, out) == hs::TimeAnswer::Interpolated);
  CHECK(out(0, 0) == doctest::Approx(4.5));
  CHECK(std::isnan(out(5, 0)));  // missing at 40: not invented
  h.clear();
  CHECK(h.at(50, out) == hs::TimeAnswer::None);
}
