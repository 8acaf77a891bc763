// Models by input rate (rate_choice.hpp): which rate each input gets, that rows reach
// the chosen filter only, a lasting change of rate moves to another, and through
// make_filter the answers are exactly those of the chosen model alone.
#include "allocation_counting.hpp"
#include "test_support.hpp"

#include "handsteady/filters.hpp"
#include "handsteady/rate_choice.hpp"
#include "handsteady/stgae_model.hpp"

#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>
#include <vector>

namespace {

// Counts its rows and answers its own id in every coordinate.
struct Probe final : hs::PoseFilter {
  double id = 0.0;
  int pushes = 0, resets = 0, restarts = 0;
  double last = std::nan("");
  explicit Probe(double i) : id(i) {}
  void reset() noexcept override {
    ++resets;
    last = std::nan("");
  }
  void restart() noexcept override {
    ++restarts;
    last = std::nan("");
  }
  bool push(double t, const hs::Pose&) noexcept override {
    if (!hs::is_next_time(t, last)) return false;
    last = t;
    ++pushes;
    return true;
  }
  void estimate(double, hs::Pose& out) const noexcept override { out.setConstant(id); }
  double last_time() const noexcept override { return last; }
};

struct Pair {
  Probe *slow = nullptr, *fast = nullptr;
  std::unique_ptr<hs::PoseFilter> filter;
};
Pair probes() {
  auto s = std::make_unique<Probe>(30.0), f = std::make_unique<Probe>(90.0);
  Pair p{s.get(), f.get(), nullptr};
  std::vector<hs::RateFilter> v;
  v.push_back({30.0, std::move(s)});
  v.push_back({90.0, std::move(f)});
  p.filter = hs::make_rate_chosen_filter(std::move(v));
  return p;
}

double answer(const hs::PoseFilter& f) {
  hs::Pose out;
  f.estimate(f.last_time(), out);
  return out(0, 0);
}

}  // namespace

TEST_CASE("the fastest model rate the input reaches, within the slack, else the slowest") {
  const std::array<double, 2> rates{30.0, 90.0};
  CHECK(hs::choose_rate(rates, 90.0) == 1);
  CHECK(hs::choose_rate(rates, 120.0) == 1);
  CHECK(hs::choose_rate(rates, 75.0) == 1);  // 75 Hz under the 90 Hz model locks (1.2 periods)
  CHECK(hs::choose_rate(rates, 60.0) == 0);  // two streams of the 30 Hz model, not resampled to 90
  CHECK(hs::choose_rate(rates, 45.0) == 0);
  CHECK(hs::choose_rate(rates, 20.0) == 0);  // slower than every model: the slowest
  const std::array<double, 2> reversed{90.0, 30.0};
  CHECK(hs::choose_rate(reversed, 90.0) == 0);
  CHECK(hs::choose_rate(reversed, 10.0) == 1);
  const std::array<double, 1> one{30.0};
  CHECK(hs::choose_rate(one, 200.0) == 0);
  CHECK(hs::choose_rate(one, 5.0) == 0);
}

TEST_CASE("rows go to every filter until the rate is known, then to the chosen one only") {
  for (const double hz : {90.0, 60.0}) {
    CAPTURE(hz);
    Pair p = probes();
    const hs::Pose pose = hs::test::synthetic_hand();
    CHECK(answer(*p.filter) == 30.0);  // the first model answers until the rate is known
    for (int i = 0; i < 40; ++i) REQUIRE(p.filter->push(i / hz, pose));
    Probe* chosen = hz == 90.0 ? p.fast : p.slow;
    Probe* other = hz == 90.0 ? p.slow : p.fast;
    CHECK(chosen->pushes == 40);
    CHECK(other->pushes == hs::kRateChoiceRows);
    CHECK(answer(*p.filter) == chosen->id);
    CHECK(p.filter->last_time() == doctest::Approx(39 / hz));
    CHECK_FALSE(p.filter->push(39 / hz, pose));  // not after the last row: refused
    p.filter->reset();
    CHECK(std::isnan(p.filter->last_time()));
    CHECK(answer(*p.filter) == 30.0);
  }
}

TEST_CASE("irregular times choose by their median, a lasting change of rate moves and a short one does not") {
  Pair p = probes();
  const hs::Pose pose = hs::test::synthetic_hand();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  double t = 0.0;
  for (int i = 0; i < 60; ++i) REQUIRE(p.filter->push(t += (1.0 + jitter(rng)) / 90.0, pose));
  CHECK(answer(*p.filter) == 90.0);
  // Five slow rows (a stall) are not a new rate.
  for (int i = 0; i < 5; ++i) REQUIRE(p.filter->push(t += 1.0 / 30.0, pose));
  for (int i = 0; i < 30; ++i) REQUIRE(p.filter->push(t += 1.0 / 90.0, pose));
  CHECK(answer(*p.filter) == 90.0);
  const int resets = p.slow->resets;
  // The runtime drops to 30 Hz for good: the 30 Hz model takes over from a fresh start.
  for (int i = 0; i < 40; ++i) REQUIRE(p.filter->push(t += 1.0 / 30.0, pose));
  CHECK(answer(*p.filter) == 30.0);
  CHECK(p.slow->resets == resets + 1);
  CHECK(p.slow->last == doctest::Approx(t));
}

TEST_CASE("a restart of the same hand restarts each filter and keeps the rate chosen, a reset does not") {
  Pair p = probes();
  const hs::Pose pose = hs::test::synthetic_hand();
  double t = 0.0;
  for (int i = 0; i < 40; ++i) REQUIRE(p.filter->push(t += 1.0 / 90.0, pose));
  REQUIRE(answer(*p.filter) == 90.0);
  const int slow_resets = p.slow->resets, fast_resets = p.fast->resets, slow_pushes = p.slow->pushes;
  p.filter->restart();
  CHECK(p.slow->restarts == 1);
  CHECK(p.fast->restarts == 1);
  CHECK(p.slow->resets == slow_resets);  // what each learnt of the hand is kept
  CHECK(p.fast->resets == fast_resets);
  CHECK(std::isnan(p.filter->last_time()));
  CHECK(answer(*p.filter) == 90.0);  // the same runtime: no new choice
  // Tracking resumes after a second's gap at the same rate: the 90 Hz model takes every row.
  t += 1.0;
  for (int i = 0; i < 20; ++i) REQUIRE(p.filter->push(t += 1.0 / 90.0, pose));
  CHECK(p.slow->pushes == slow_pushes);
  CHECK(answer(*p.filter) == 90.0);
  p.filter->reset();
  CHECK(p.fast->resets == fast_resets + 1);
  CHECK(answer(*p.filter) == 30.0);  // another hand: chosen anew
}

TEST_CASE("the chooser allocates nothing per row") {
  Pair p = probes();
  const hs::Pose pose = hs::test::synthetic_hand();
  hs::Pose out;
  hs::test::g_allocations = 0;
  hs::test::g_counting = true;
  for (int i = 0; i < 200; ++i) {
    p.filter->push(i / (i < 100 ? 90.0 : 30.0), pose);
    p.filter->estimate(i / 90.0, out);
  }
  hs::test::g_counting = false;
  CHECK(hs::test::g_allocations.load() == 0);
}

TEST_CASE("make_rate_chosen_filter refuses what it cannot choose among") {
  CHECK_THROWS_AS(hs::make_rate_chosen_filter({}), std::invalid_argument);
  auto two = [](double a, double b, bool null_second) {
    std::vector<hs::RateFilter> v;
    v.push_back({a, std::make_unique<Probe>(a)});
    v.push_back({b, null_second ? nullptr : std::make_unique<Probe>(b)});
    return v;
  };
  CHECK_THROWS_AS(hs::make_rate_chosen_filter(two(30, 90, true)), std::invalid_argument);
  CHECK_THROWS_AS(hs::make_rate_chosen_filter(two(30, 30, false)), std::invalid_argument);
  CHECK_THROWS_AS(hs::make_rate_chosen_filter(two(30, 0, false)), std::invalid_argument);
  CHECK_THROWS_AS(hs::make_rate_chosen_filter(two(30, std::nan(""), false)), std::invalid_argument);
  std::vector<hs::RateFilter> one;
  one.push_back({30.0, std::make_unique<Probe>(7.0)});
  const auto f = hs::make_rate_chosen_filter(std::move(one));
  CHECK(answer(*f) == 7.0);  // one model: that filter itself
}

namespace {
std::shared_ptr<const hs::StgaeModel> small_model(double rate_hz, std::uint64_t seed) {
  hs::StgaeConfig c;
  c.window = 4;
  c.horizon = 2;
  c.rate_hz = rate_hz;
  c.encoder_channels = {6, 8, 8};
  c.denoise_decoder_channels = {8, 6, 3};
  c.predict_decoder_channels = {8, 6, 3};
  c.temporal_kernel = 3;
  auto w = hs::random_stgae_weights(c, seed, 1.0);
  auto ref = hs::make_stgae_reference(c, w, hs::synthetic_hand_input(c, c.window, seed));
  return hs::make_stgae_model(c, std::move(w), std::move(ref));
}

// The largest difference between two filters' answers (now and 50 ms ahead) over a moving,
// jittered hand at hz, from the row at which the rate is known.
double worst_difference(hs::PoseFilter& a, hs::PoseFilter& b, double hz) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 0.002);
  double worst = 0.0;
  hs::Pose oa, ob;
  for (int i = 0; i < 120; ++i) {
    const double t = i / hz;
    hs::Pose p = hs::test::synthetic_hand();
    p.col(0).array() += 0.05 * std::sin(2.0 * t);
    p = hs::test::jittered(p, rng, noise);
    a.push(t, p);
    b.push(t, p);
    for (const double h : {0.0, 0.05}) {
      if (i < hs::kRateChoiceRows - 1) continue;
      a.estimate(t + h, oa);
      b.estimate(t + h, ob);
      worst = std::max(worst, (oa - ob).cwiseAbs().maxCoeff());
    }
  }
  return worst;
}
}  // namespace

TEST_CASE("through make_filter each input gets exactly the answers of its model alone") {
  hs::FilterConfig pair;
  pair.method = hs::FilterMethod::Stgae;
  pair.stgae.model = small_model(30.0, 1);
  pair.stgae.rate_models = {small_model(90.0, 2)};
  for (const double hz : {90.0, 60.0, 20.0}) {
    CAPTURE(hz);
    hs::FilterConfig alone = pair;
    alone.stgae.rate_models.clear();
    if (hz == 90.0) alone.stgae.model = pair.stgae.rate_models[0];
    auto a = hs::make_filter(pair), b = hs::make_filter(alone);
    CHECK(worst_difference(*a, *b, hz) == 0.0);
    // ... and not those of the other model (the check can fail).
    hs::FilterConfig other = alone;
    other.stgae.model = hz == 90.0 ? pair.stgae.model : pair.stgae.rate_models[0];
    auto c = hs::make_filter(pair), d = hs::make_filter(other);
    CHECK(worst_difference(*c, *d, hz) > 1e-4);
  }
  CHECK(hs::filter_params_summary(pair).find("rate_models=90") != std::string::npos);
  // Two models at one rate, or one of another family, cannot be chosen among.
  hs::FilterConfig same = pair;
  same.stgae.rate_models = {small_model(30.0, 3)};
  CHECK_THROWS_AS(hs::make_filter(same), std::invalid_argument);
  hs::FilterConfig missing = pair;
  missing.stgae.rate_models = {nullptr};
  CHECK_THROWS_AS(hs::make_filter(missing), std::invalid_argument);
  hs::FilterConfig unpaired = pair;  // rate models with no model of the method's own
  unpaired.stgae.model = nullptr;
  CHECK_THROWS_AS(hs::make_filter(unpaired), std::invalid_argument);
}
