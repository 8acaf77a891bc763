// `handsteady filter --method stgae`: the streaming engine over tracks at 20-120 Hz and
// irregular timestamps (rows, times, untracked rows kept; causal; the resampling onto the
// model grid checked analytically with a zero-offset model), model resolution and bad
// model files, and `--offline` window mode with a centred model (checked against the
// engine's window forward).
#include "handsteady/hsm_format.hpp"
#include "handsteady/model_path.hpp"
#include "handsteady/stgae_engine.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/track.hpp"

#include "test_support.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

using hs::Hand;
using hs::Pose;
using Vec3 = Eigen::Vector3d;
namespace fs = std::filesystem;

hs::StgaeConfig small_config(hs::StgaePadding padding) {
  hs::StgaeConfig c;
  c.window = padding == hs::StgaePadding::Causal ? 4 : 5;
  c.horizon = 2;
  c.rate_hz = 30.0;
  c.encoder_channels = {6, 8, 8};
  c.denoise_decoder_channels = {8, 6, 3};
  c.predict_decoder_channels = {8, 6, 3};
  c.temporal_kernel = 3;
  c.padding = padding;
  return c;
}

// Every tensor zero except BN running variances (1): all offsets are 0, so the model's
// denoised frame is its (hole-filled) input and every predicted frame repeats it.
hs::StgaeWeights zero_weights(const hs::StgaeConfig& c) {
  hs::StgaeWeights w;
  for (const auto& s : hs::stgae_tensor_specs(c)) {
    hs::Tensor t;
    t.shape = s.shape;
    const bool var = s.name.size() >= 12 && s.name.compare(s.name.size() - 12, 12, "running_var") == 0;
    t.data.assign(s.numel(), var ? 1.0f : 0.0f);
    w.tensors.emplace(s.name, std::move(t));
  }
  return w;
}

fs::path write_model(const fs::path& file, const hs::StgaeConfig& c, const hs::StgaeWeights& w) {
  hs::save_hsm(file, c, w, hs::make_stgae_reference(c, w, hs::synthetic_hand_input(c, c.window, 3)));
  return file;
}

// A hand whose joint j sits at base + offset_j and moves with velocity v (m/s).
Pose ramp_pose(const Vec3& base, const Vec3& v, double t) {
  Pose p;
  for (int j = 0; j < hs::kJointCount; ++j) {
    const Vec3 off(0.01 * (j % 5), 0.012 * (j / 5), -0.004 * j);
    p.row(j) = (base + off + v * t).transpose();
  }
  return p;
}

const Vec3 kLeftBase(-0.2, 1.0, -0.4), kRightBase(0.25, 1.1, -0.35);
const Vec3 kLeftV(0.3, -0.1, 0.05), kRightV(-0.05, 0.2, 0.1);

// Both hands on ramps at the given row times; the left hand is untracked for rows in
// [lost_from, lost_to] (by time), the right hand misses joint 7 at row `missing_row` (-1: never).
hs::Track ramp_track(const std::vector<double>& times, double lost_from = 1e9, double lost_to = -1e9,
                     int missing_row = -1) {
  hs::Track track;
  track.header_lines.push_back("source: test_cli_stgae");
  for (size_t i = 0; i < times.size(); ++i) {
    const double t = times[i];
    hs::TrackRow l{t, Hand::Left, ramp_pose(kLeftBase, kLeftV, t)};
    if (t >= lost_from && t <= lost_to) l.pos = hs::untracked_pose();
    hs::TrackRow r{t + 0.002, Hand::Right, ramp_pose(kRightBase, kRightV, t + 0.002)};
    if (static_cast<int>(i) == missing_row) r.pos.row(7).setConstant(std::nan(""));
    track.rows.push_back(l);
    track.rows.push_back(r);
  }
  return track;
}

std::vector<double> regular_times(double rate_hz, double duration_s) {
  std::vector<double> t;
  for (int i = 0; i / rate_hz < duration_s; ++i) t.push_back(i / rate_hz);
  return t;
}

// 30-110 Hz with jitter: periods drawn deterministically from [min_s, max_s] (9-33 ms).
std::vector<double> irregular_times(double duration_s, double min_s = 0.009, double max_s = 0.033) {
  std::vector<double> t{0.0};
  std::uint64_t s = 12345;
  while (t.back() < duration_s) {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    const double u = static_cast<double>(s >> 11) / 9007199254740992.0;
    t.push_back(t.back() + min_s + (max_s - min_s) * u);
  }
  return t;
}

std::string quoted(const fs::path& p) { return "\"" + p.string() + "\""; }

int filter_cli(const fs::path& in, const fs::path& out, const std::string& options, const fs::path& err = {}) {
  std::string cmd = "filter --in " + quoted(in) + " --out " + quoted(out) + " " + options;
  if (!err.empty()) cmd += " 2> " + quoted(err);
  return hs::test::run_cli(cmd);
}

hs::Track run_ok(const hs::Track& input, const fs::path& dir, const std::string& options) {
  hs::write_track_csv(input, dir / "in.csv");
  REQUIRE(filter_cli(dir / "in.csv", dir / "out.csv", options) == 0);
  return hs::read_track_csv(dir / "out.csv");
}

using hs::test::slurp;

// Rows, times, hands and untracked rows as in the input; tracked rows fully finite
// (except joints allowed NaN by `allow_nan_joint`) and within `max_dev_m` of the input.
void check_structure(const hs::Track& in, const hs::Track& out, double max_dev_m) {
  REQUIRE(out.rows.size() == in.rows.size());
  for (size_t i = 0; i < in.rows.size(); ++i) {
    CAPTURE(i);
    const hs::TrackRow& a = in.rows[i];
    const hs::TrackRow& b = out.rows[i];
    REQUIRE(a.t == b.t);
    REQUIRE(a.hand == b.hand);
    REQUIRE(hs::any_joint_tracked(a.pos) == hs::any_joint_tracked(b.pos));
    if (!hs::any_joint_tracked(a.pos)) continue;
    for (int j = 0; j < hs::kJointCount; ++j) {
      REQUIRE(std::isfinite(b.pos(j, 0)));
      REQUIRE(b.pos.row(j).allFinite());
      if (hs::joint_tracked(a.pos, j)) CHECK((b.pos.row(j) - a.pos.row(j)).norm() < max_dev_m);
    }
  }
}

struct Models {
  fs::path dir, random_causal, zero_causal, random_centred, zero_centred, random_dgn;
};
const Models& models() {
  static const Models m = [] {
    Models r;
    r.dir = hs::test::temp_dir("cli_stgae_models");
    const auto causal = small_config(hs::StgaePadding::Causal);
    const auto centred = small_config(hs::StgaePadding::Centred);
    r.random_causal = write_model(r.dir / "random_causal.hsm", causal, hs::random_stgae_weights(causal, 17, 1.0));
    r.zero_causal = write_model(r.dir / "zero_causal.hsm", causal, zero_weights(causal));
    r.random_centred = write_model(r.dir / "random_centred.hsm", centred, hs::random_stgae_weights(centred, 19, 1.0));
    r.zero_centred = write_model(r.dir / "zero_centred.hsm", centred, zero_weights(centred));
    auto dgn = causal;
    dgn.family = hs::StgaeFamily::Dgn;
    dgn.gates = false;
    r.random_dgn = write_model(r.dir / "random_dgn.hsm", dgn, hs::random_stgae_weights(dgn, 23, 1.0));
    return r;
  }();
  return m;
}

// The streaming adapter pushes a frame at each model tick t0 + k/30 s (t0 = the first
// sample after a reset) once an input sample at or after it arrives, and with zero offsets
// answers the frame of the latest tick. (Same accumulation and tolerance as the adapter,
// so that samples a rounding error before a tick agree.)
// The model grid: t0 + k / 30 s from the first sample; a tick up to 1 us after a row
// counts as at the row (rounded CSV times).
struct Ticks {
  double t0 = std::nan("");
  long k = 0;
  double at(double t) {
    const double p = 1.0 / 30.0;
    if (std::isnan(t0)) t0 = t;
    while (t0 + static_cast<double>(k + 1) * p <= t + 1e-6) ++k;
    return t0 + static_cast<double>(k) * p;
  }
};

}  // namespace

TEST_CASE("stgae streams at 20, 30, 90 and 120 Hz and on irregular timestamps, rows are kept") {
  const fs::path dir = hs::test::temp_dir("cli_stgae_rates");
  for (const double rate : {20.0, 30.0, 90.0, 120.0, 0.0}) {
    CAPTURE(rate);
    const auto times = rate > 0 ? regular_times(rate, 1.5) : irregular_times(1.5);
    // Left hand lost for ~0.1 s (bridged) and for 0.5 s (the stream restarts).
    const hs::Track built = ramp_track(times, 0.5, 0.6, 5);
    hs::write_track_csv(built, dir / "in.csv");
    const hs::Track in = hs::read_track_csv(dir / "in.csv");
    const hs::Track out = run_ok(in, dir, "--method stgae --model " + quoted(models().random_causal));
    // A random model does not denoise; it must stay finite and on the hand's scale.
    check_structure(in, out, 0.5);
    CHECK(out.meta("filter").value_or("").find("stgae horizon_ms=0 model=") == 0);
    const hs::Track ahead = run_ok(in, dir, "--method stgae --horizon-ms 50 --model " + quoted(models().random_causal));
    check_structure(in, ahead, 0.5);
    CHECK((ahead.rows[40].pos - out.rows[40].pos).norm() > 1e-6);  // the horizon is used
  }
  fs::remove_all(dir);
}

TEST_CASE("stgae with one stream and a zero-offset model: the ramp at the latest model tick on the grid (the row itself before the first tick), the input itself where frames lock to the samples") {
  // One stream under a 30 Hz model: 90 Hz, 120 Hz and irregular 67-110 Hz run on the model's
  // grid (a third of a period and less: too fine to lock); 45 Hz (0.67 periods) locks, and
  // 20 Hz (1.5) locks with each interval split into two frames, so there every row after
  // the first kRateRows (the rate unknown: on the grid) is answered by its own frame.
  const fs::path dir = hs::test::temp_dir("cli_stgae_zero");
  for (const double rate : {20.0, 45.0, 90.0, 120.0, 0.0}) {
    CAPTURE(rate);
    const bool locks = rate == 20.0 || rate == 45.0;
    const auto times = rate > 0 ? regular_times(rate, 2.0) : irregular_times(2.0, 0.009, 0.015);
    // Left: lost for 0.5 s from t = 1 s (longer than kModelResetGapS: the grid restarts).
    hs::write_track_csv(ramp_track(times, 1.0, 1.5), dir / "in.csv");
    const hs::Track in = hs::read_track_csv(dir / "in.csv");
    // Unbounded: the trust region would pull the held ticks onto the moving input.
    const hs::Track out = run_ok(in, dir, "--method stgae --unbounded --phases 1 --model " + quoted(models().zero_causal));
    REQUIRE(out.rows.size() == in.rows.size());
    Ticks left_ticks, right_ticks;
    bool left_lost = false;
    int left_rows = 0, right_rows = 0;
    double max_err = 0.0;
    for (size_t i = 0; i < in.rows.size(); ++i) {
      const hs::TrackRow& a = in.rows[i];
      const hs::TrackRow& b = out.rows[i];
      const bool left = a.hand == Hand::Left;
      if (!hs::any_joint_tracked(a.pos)) {
        CHECK_FALSE(hs::any_joint_tracked(b.pos));
        left_lost = true;
        continue;
      }
      Ticks& ticks = left ? left_ticks : right_ticks;
      if (left && left_lost) ticks = Ticks{};  // lost > kModelResetGapS: the grid restarts
      if (left) left_lost = false;
      if (locks) {
        // After each hand's first rows (the rate unknown; the left hand's restart after its
        // gap knows the rate and locks at once).
        if (++(left ? left_rows : right_rows) <= 5) continue;
        max_err = std::max(max_err, (b.pos - a.pos).cwiseAbs().maxCoeff());
        continue;
      }
      const double tick = ticks.at(a.t);
      // Before the grid's first tick after its start the grid has framed one row and knows
      // no motion: the row answers itself (not the start row held).
      const Pose expected = ticks.k == 0 ? a.pos
                            : left       ? ramp_pose(kLeftBase, kLeftV, tick)
                                         : ramp_pose(kRightBase, kRightV, tick);
      if (ticks.k == 0 && a.t > ticks.t0) ++(left ? left_rows : right_rows);
      max_err = std::max(max_err, (b.pos - expected).cwiseAbs().maxCoeff());
    }
    CHECK(max_err < 1e-4);  // float model arithmetic and CSV precision
    // Rows before the first tick, of both starts of the left hand and the right's start.
    if (!locks) CHECK(left_rows + right_rows >= 3);
    // Not the trivial answer on the grid: the held tick lags the input on a moving hand.
    if (!locks) CHECK((out.rows[21].pos - in.rows[21].pos).cwiseAbs().maxCoeff() > 1e-3);
  }
  fs::remove_all(dir);
}

TEST_CASE("stgae at 90 Hz (3 streams by default) with a zero-offset model: each row from its own tick and the one before") {
  // Every 90 Hz row is a tick of one of the three 30 Hz streams. With zero offsets the
  // answer is (ramp(t) + 0.5 ramp(t - 1/90 s)) / 1.5 = ramp(t - 1/270 s) once all streams
  // have a window of history; one stream would hold ramp(latest 30 Hz tick) instead.
  const fs::path dir = hs::test::temp_dir("cli_stgae_phases");
  hs::write_track_csv(ramp_track(regular_times(90.0, 2.0)), dir / "in.csv");
  const hs::Track in = hs::read_track_csv(dir / "in.csv");
  const hs::Track out = run_ok(in, dir, "--method stgae --unbounded --model " + quoted(models().zero_causal));
  REQUIRE(out.rows.size() == in.rows.size());
  CHECK(out.meta("filter").value_or("").find("phases=auto unbounded") != std::string::npos);
  const hs::Track gained = run_ok(in, dir, "--method stgae --gain --model " + quoted(models().zero_causal));
  CHECK(gained.meta("filter").value_or("").find("phases=auto gain") != std::string::npos);
  const hs::Track ungained = run_ok(in, dir, "--method stgae --no-gain --model " + quoted(models().zero_causal));
  CHECK(ungained.meta("filter").value_or("").find("phases=auto no-gain") != std::string::npos);
  const hs::Track smooth = run_ok(in, dir, "--method stgae --smooth-predictions --model " + quoted(models().zero_causal));
  CHECK(smooth.meta("filter").value_or("").find("phases=auto smoothed") != std::string::npos);
  double max_err = 0.0, start_err = 0.0;
  long n = 0, start_rows = 0;
  for (size_t i = 0; i < in.rows.size(); ++i) {
    const hs::TrackRow& a = in.rows[i];
    const double t0 = in.rows[a.hand == in.rows.front().hand ? 0 : 1].t;  // the hand's first row
    if (a.t > t0 && a.t - t0 < 1.0 / 30.0 - 1e-6) {
      // Before the grid's first tick: the moving hand's rows answer themselves (the start
      // row held would be 1-2 rows of the ramp behind), with every option.
      for (const hs::Track* o : {&out, &gained, &ungained, &smooth})
        start_err = std::max(start_err, (o->rows[i].pos - a.pos).cwiseAbs().maxCoeff());
      ++start_rows;
    }
    if (a.t - in.rows.front().t < 1.0) continue;  // warm-up
    const bool left = a.hand == Hand::Left;
    const Pose expected = left ? ramp_pose(kLeftBase, kLeftV, a.t - 1.0 / 270.0) : ramp_pose(kRightBase, kRightV, a.t - 1.0 / 270.0);
    max_err = std::max(max_err, (out.rows[i].pos - expected).cwiseAbs().maxCoeff());
    ++n;
  }
  CHECK(n > 150);
  CHECK(max_err < 1e-4);
  CHECK(start_rows == 4);  // two rows of each hand
  CHECK(start_err < 1e-6);
  fs::remove_all(dir);
}

TEST_CASE("stgae is causal: a truncated input gives a prefix of the output") {
  const fs::path dir = hs::test::temp_dir("cli_stgae_causal");
  const hs::Track built = ramp_track(irregular_times(1.5), 0.4, 0.45, 10);
  hs::write_track_csv(built, dir / "in.csv");
  const hs::Track in = hs::read_track_csv(dir / "in.csv");
  const std::string opts = "--method stgae --horizon-ms 30 --model " + quoted(models().random_causal);
  const hs::Track full = run_ok(in, dir, opts);
  hs::Track prefix = in;
  prefix.rows.resize(in.rows.size() / 2 + 1);
  const hs::Track part = run_ok(prefix, dir, opts);
  REQUIRE(part.rows.size() == prefix.rows.size());
  for (size_t i = 0; i < part.rows.size(); ++i) {
    CAPTURE(i);
    CHECK(part.rows[i].t == full.rows[i].t);
    for (int j = 0; j < hs::kJointCount; ++j)
      for (int c = 0; c < 3; ++c) {
        const double x = part.rows[i].pos(j, c), y = full.rows[i].pos(j, c);
        CHECK(((std::isnan(x) && std::isnan(y)) || x == y));
      }
  }
  fs::remove_all(dir);
}

TEST_CASE("dgn streams like stgae, and each method refuses the other family's model naming the file and the method to use") {
  const fs::path dir = hs::test::temp_dir("cli_dgn");
  const hs::Track built = ramp_track(regular_times(90, 1.0), 0.5, 0.6, 5);
  hs::write_track_csv(built, dir / "in.csv");
  const hs::Track in = hs::read_track_csv(dir / "in.csv");
  const hs::Track out = run_ok(in, dir, "--method dgn --model " + quoted(models().random_dgn));
  check_structure(in, out, 0.5);
  CHECK(out.meta("filter").value_or("").find("dgn horizon_ms=0 model=") == 0);
  const hs::Track ahead = run_ok(in, dir, "--method dgn --horizon-ms 50 --model " + quoted(models().random_dgn));
  check_structure(in, ahead, 0.5);
  CHECK((ahead.rows[40].pos - out.rows[40].pos).norm() > 1e-6);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method stgae --model " + quoted(models().random_dgn),
                   dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find(models().random_dgn.string()) != std::string::npos);
  CHECK(slurp(dir / "err.txt").find("--method dgn") != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method dgn --model " + quoted(models().random_causal),
                   dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--method stgae") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("stgae --rate-model: each hand runs the model of its input's rate, and a model that cannot join is refused naming it") {
  const fs::path dir = hs::test::temp_dir("cli_rate_model");
  auto fast = small_config(hs::StgaePadding::Causal);
  fast.rate_hz = 90;
  const fs::path m90 = write_model(dir / "random_90.hsm", fast, hs::random_stgae_weights(fast, 29, 1.0));
  hs::Track built = ramp_track(regular_times(90, 1.0), 0.5, 0.6, 5);
  // 1 mm of deterministic jitter: on a clean ramp every model is held to the input itself,
  // and the two models' answers could not be told apart.
  for (size_t i = 0; i < built.rows.size(); ++i)
    for (int j = 0; j < built.rows[i].pos.rows(); ++j)
      for (int c = 0; c < 3; ++c) built.rows[i].pos(j, c) += 0.001 * std::sin(1.7 * static_cast<double>(i) + 0.3 * j + c);
  hs::write_track_csv(built, dir / "in.csv");
  const hs::Track in = hs::read_track_csv(dir / "in.csv");
  const std::string pair = "--method stgae --model " + quoted(models().random_causal) + " --rate-model " + quoted(m90);
  const hs::Track out = run_ok(in, dir, pair);
  check_structure(in, out, 0.5);
  CHECK(out.meta("filter").value_or("").find("rate_models=90") != std::string::npos);
  // At 90 Hz the answers are the 90 Hz model's alone (after the first rows, which measure the rate).
  const hs::Track alone = run_ok(in, dir, "--method stgae --model " + quoted(m90));
  const hs::Track slow = run_ok(in, dir, "--method stgae --model " + quoted(models().random_causal));
  double to_alone = 0.0, to_slow = 0.0;
  for (size_t i = 0; i < out.rows.size(); ++i) {
    if (out.rows[i].t < 0.1 || !out.rows[i].pos.allFinite() || !alone.rows[i].pos.allFinite()) continue;
    to_alone = std::max(to_alone, (out.rows[i].pos - alone.rows[i].pos).cwiseAbs().maxCoeff());
    to_slow = std::max(to_slow, (out.rows[i].pos - slow.rows[i].pos).cwiseAbs().maxCoeff());
  }
  CHECK(to_alone == 0.0);
  CHECK(to_slow > 1e-5);
  // A second model at the same rate, a centred one, or one for a classical method: status 2.
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv",
                   "--method stgae --model " + quoted(models().random_causal) + " --rate-model " +
                       quoted(models().zero_causal), dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("Hz") != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method stgae --model " + quoted(models().random_causal) + " --rate-model " +
                       quoted(models().random_centred),
                   dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find(models().random_centred.string()) != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method oneeuro --rate-model " + quoted(m90), dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--rate-model") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("stgae model errors: bad, missing or centred model files exit with status 2 naming the file") {
  const fs::path dir = hs::test::temp_dir("cli_stgae_bad");
  hs::write_track_csv(ramp_track(regular_times(30, 0.5)), dir / "in.csv");
  const fs::path bad = dir / "garbage.hsm";
  std::ofstream(bad) << "HSM1 but not really a model";
  // A valid model with one byte flipped in the middle: the checksum catches it.
  std::vector<char> bytes;
  {
    std::ifstream f(models().random_causal, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
  const fs::path flipped = dir / "flipped.hsm";
  std::ofstream(flipped, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));

  for (const fs::path& model : {bad, flipped, dir / "absent.hsm"}) {
    CAPTURE(model);
    CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method stgae --model " + quoted(model), dir / "err.txt") == 2);
    CHECK(slurp(dir / "err.txt").find(model.string()) != std::string::npos);
  }
  // Centred models do not stream; causal ones are not for --offline.
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method stgae --model " + quoted(models().random_centred),
                   dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--offline") != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv",
                   "--method stgae --offline --model " + quoted(models().random_causal), dir / "err.txt") == 2);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method oneeuro --model " + quoted(models().random_causal)) == 2);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method kalman --offline") == 2);
  // --unbounded: Multi-STGAE streaming only.
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method kalman --unbounded", dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--unbounded") != std::string::npos);
  // --gain: Multi-STGAE streaming with its trust region only.
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method kalman --gain", dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--gain") != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv",
                   "--method stgae --gain --unbounded --model " + quoted(models().random_causal), dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--gain") != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method kalman --no-gain", dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--no-gain") != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv",
                   "--method stgae --gain --no-gain --model " + quoted(models().random_causal), dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("contradict") != std::string::npos);
  // --smooth-predictions: Multi-STGAE streaming with its trust region only.
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method kalman --smooth-predictions", dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--smooth-predictions") != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv",
                   "--method stgae --smooth-predictions --unbounded --model " + quoted(models().random_causal),
                   dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--smooth-predictions") != std::string::npos);
  // --phases: Multi-STGAE only, 0..4.
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method kalman --phases 2", dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("--phases") != std::string::npos);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv",
                   "--method stgae --phases 9 --model " + quoted(models().random_causal), dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find("phases") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("stgae default model: HANDSTEADY_MODEL, else a clear error naming the paths tried") {
  const fs::path dir = hs::test::temp_dir("cli_stgae_default");
  hs::write_track_csv(ramp_track(regular_times(30, 0.5)), dir / "in.csv");
  ::setenv("HANDSTEADY_MODEL", models().zero_causal.c_str(), 1);
  CHECK(hs::default_model_path() == models().zero_causal);
  REQUIRE(filter_cli(dir / "in.csv", dir / "out.csv", "--method stgae") == 0);
  CHECK(hs::read_track_csv(dir / "out.csv").meta("filter").value_or("").find(models().zero_causal.string()) != std::string::npos);

  const fs::path absent = dir / "no_such_model.hsm";
  ::setenv("HANDSTEADY_MODEL", absent.c_str(), 1);
  CHECK_THROWS_AS(hs::default_model_path(), hs::InputError);
  CHECK(filter_cli(dir / "in.csv", dir / "out.csv", "--method stgae", dir / "err.txt") == 2);
  CHECK(slurp(dir / "err.txt").find(absent.string()) != std::string::npos);
  ::unsetenv("HANDSTEADY_MODEL");

  // Without the variable: only the installed location next to an executable (no path from
  // the build, such as the source tree, is compiled in).
  const auto r = hs::lookup_default_model({dir / "share"});
  REQUIRE(r.tried.size() == 1);
  CHECK(r.tried[0] == dir / "share" / hs::kDefaultModelFile);
  CHECK(r.found.empty());
  fs::create_directories(dir / "share");
  fs::copy_file(models().zero_causal, dir / "share" / hs::kDefaultModelFile);
  CHECK(hs::lookup_default_model({dir / "share"}).found == dir / "share" / hs::kDefaultModelFile);
  fs::remove_all(dir);
}

TEST_CASE("stgae --offline: centred window mode over the recording, each frame from its centred window") {
  const fs::path dir = hs::test::temp_dir("cli_stgae_offline");
  // 30 Hz rows on the model grid (so the resampling is the identity) with a 0.5 s loss
  // (two segments) and a short 3-frame segment at the end (shorter than the window: padded).
  std::vector<double> times = regular_times(30.0, 2.0);
  for (double t : {2.5, 2.5 + 1 / 30.0, 2.5 + 2 / 30.0}) times.push_back(t);
  hs::write_track_csv(ramp_track(times, 0.9, 1.4, 12), dir / "in.csv");
  const hs::Track in = hs::read_track_csv(dir / "in.csv");

  // Zero offsets: the output is the ramp itself, at every row (including padded segments).
  const hs::Track zero = run_ok(in, dir, "--method stgae --offline --model " + quoted(models().zero_centred));
  REQUIRE(zero.rows.size() == in.rows.size());
  for (size_t i = 0; i < in.rows.size(); ++i) {
    CAPTURE(i);
    CHECK(hs::any_joint_tracked(zero.rows[i].pos) == hs::any_joint_tracked(in.rows[i].pos));
    if (!hs::any_joint_tracked(in.rows[i].pos)) continue;
    const Pose expected = in.rows[i].hand == Hand::Left ? ramp_pose(kLeftBase, kLeftV, in.rows[i].t)
                                                         : ramp_pose(kRightBase, kRightV, in.rows[i].t);
    for (int j = 0; j < hs::kJointCount; ++j) {
      REQUIRE(zero.rows[i].pos.row(j).allFinite());
      // A joint missing in its row is estimated from a neighbouring sample: not exact.
      if (hs::joint_tracked(in.rows[i].pos, j))
        CHECK((zero.rows[i].pos.row(j) - expected.row(j)).cwiseAbs().maxCoeff() < 1e-4);
    }
  }

  // A random centred model: interior frame k equals the centre frame of the window k-2..k+2.
  const hs::Track out = run_ok(in, dir, "--method stgae --offline --model " + quoted(models().random_centred));
  check_structure(in, out, 0.5);
  CHECK(out.meta("filter").value_or("").find("mode=offline") != std::string::npos);
  const auto model = hs::load_hsm(models().random_centred);
  const hs::HandSeries right = hs::hand_series(in, Hand::Right);
  const hs::HandSeries right_out = hs::hand_series(out, Hand::Right);
  const int T = model->config.window, c = (T - 1) / 2, n = hs::kJointCount;
  for (int k : {c, 20, 40}) {
    CAPTURE(k);
    hs::StgaeFrames<float> w(T, 3 * n);
    for (int i = 0; i < T; ++i)
      for (int j = 0; j < n; ++j)
        for (int d = 0; d < 3; ++d) w(i, 3 * j + d) = static_cast<float>(right.pos[static_cast<size_t>(k - c + i)](j, d));
    const auto y = hs::stgae_window_forward(*model->net, w);
    double err = 0.0;
    for (int j = 0; j < n; ++j)
      for (int d = 0; d < 3; ++d)
        err = std::max(err, std::abs(static_cast<double>(y.denoised(c, 3 * j + d)) - right_out.pos[static_cast<size_t>(k)](j, d)));
    CHECK(err < 1e-4);
  }
  // With a horizon (the paper's prediction protocol): row k from the window ending at k,
  // its path [denoised k, predicted k+1, k+2] read 50 ms = 1.5 periods after the row.
  const hs::Track ahead =
      run_ok(in, dir, "--method stgae --offline --horizon-ms 50 --model " + quoted(models().random_centred));
  check_structure(in, ahead, 1.0);  // random weights: predicted offsets are larger than denoised ones
  const hs::HandSeries right_ahead = hs::hand_series(ahead, Hand::Right);
  for (int k : {2, 20, 40}) {
    CAPTURE(k);
    hs::StgaeFrames<float> w(T, 3 * n);
    for (int i = 0; i < T; ++i)
      for (int j = 0; j < n; ++j)
        for (int d = 0; d < 3; ++d)
          w(i, 3 * j + d) = static_cast<float>(right.pos[static_cast<size_t>(std::max(0, k - (T - 1) + i))](j, d));
    const auto y = hs::stgae_window_forward(*model->net, w);
    double err = 0.0;
    for (int j = 0; j < n; ++j)
      for (int d = 0; d < 3; ++d) {
        const double expect = 0.5 * (static_cast<double>(y.predicted(0, 3 * j + d)) + static_cast<double>(y.predicted(1, 3 * j + d)));
        err = std::max(err, std::abs(expect - right_ahead.pos[static_cast<size_t>(k)](j, d)));
      }
    CHECK(err < 1e-4);
  }
  fs::remove_all(dir);
}
