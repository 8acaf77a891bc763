// Multi-STGAE configuration JSON, tensor specs and the .hsm model file (round trip and
// every loader error path), and two models of one network blended (hs::model_blend).
#include "handsteady/stgae_model.hpp"

#include "handsteady/hsm_format.hpp"
#include "handsteady/model_blend.hpp"
#include "handsteady/stgae_engine.hpp"
#include "test_support.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <utility>

namespace {

hs::StgaeConfig small_config() {
  hs::StgaeConfig c;
  c.window = 4;
  c.horizon = 2;
  c.encoder_channels = {6, 8, 8};
  c.denoise_decoder_channels = {8, 4, 3};
  c.predict_decoder_channels = {8, 4, 3};
  c.temporal_kernel = 3;
  return c;
}

std::vector<std::uint8_t> small_file(const hs::StgaeConfig& c, std::uint64_t seed = 1) {
  const auto w = hs::random_stgae_weights(c, seed);
  return hs::serialize_hsm(c, w, hs::make_stgae_reference(c, w, hs::synthetic_hand_input(c, c.window, seed)));
}

// FNV-1a 64 written independently of the loader.
void reseal(std::vector<std::uint8_t>& b) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (size_t i = 0; i + 8 < b.size(); ++i) h = (h ^ b[i]) * 0x100000001b3ULL;
  for (int i = 0; i < 8; ++i) b[b.size() - 8 + static_cast<size_t>(i)] = static_cast<std::uint8_t>(h >> (8 * i));
}

size_t find_bytes(const std::vector<std::uint8_t>& b, const std::string& s) {
  for (size_t i = 0; i + s.size() <= b.size(); ++i)
    if (std::memcmp(b.data() + i, s.data(), s.size()) == 0) return i;
  FAIL("not found: " << s);
  return 0;
}

std::string load_error(const std::vector<std::uint8_t>& b) {
  try {
    (void)hs::parse_hsm(b, "model.hsm");
  } catch (const hs::InputError& e) {
    return e.what();
  }
  return "";
}

hs::HsmContents small_model(const hs::StgaeConfig& c, std::uint64_t seed) {
  hs::HsmContents m;
  m.config = c;
  m.config.meta_json = "{\"seed\": " + std::to_string(seed) + "}";
  m.weights = hs::random_stgae_weights(c, seed);
  m.reference = hs::make_stgae_reference(c, m.weights, hs::synthetic_hand_input(c, c.window, seed));
  return m;
}

std::string blend_error(const hs::HsmContents& a, const hs::HsmContents& b, double alpha) {
  try {
    (void)hs::blend_models(a, "a.hsm", b, "b.hsm", alpha);
  } catch (const hs::InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("config JSON round trip, defaults and errors") {
  auto c = small_config();
  c.padding = hs::StgaePadding::Centred;
  c.c_variant = hs::StgaeCVariant::Gat;
  c.attention = hs::StgaeAttention::AB;
  c.gates = false;
  c.meta_json = R"({"epochs":3})";
  const auto back = hs::parse_stgae_config(hs::to_json(c), "x.json");
  CHECK(back.window == 4);
  CHECK(back.horizon == 2);
  CHECK(back.encoder_channels == c.encoder_channels);
  CHECK(back.padding == hs::StgaePadding::Centred);
  CHECK(back.c_variant == hs::StgaeCVariant::Gat);
  CHECK(back.attention == hs::StgaeAttention::AB);
  CHECK_FALSE(back.gates);
  CHECK(back.meta_json == R"({"epochs":3})");
  CHECK(hs::parse_stgae_config("{}").window == hs::StgaeConfig{}.window);

  auto err = [](const std::string& json) {
    try {
      (void)hs::parse_stgae_config(json, "cfg.json");
    } catch (const hs::InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(err(R"({"windw": 4})").find("windw") != std::string::npos);
  CHECK(err(R"({"window": "4"})").find("window") != std::string::npos);
  CHECK(err(R"({"padding": "acausal"})").find("padding") != std::string::npos);
  CHECK(err(R"({"temporal_kernel": 4})").find("temporal_kernel") != std::string::npos);
  CHECK(err(R"({"encoder_channels": [3, 16]})").find("encoder_channels") != std::string::npos);
  CHECK(err(R"({"denoise_decoder_channels": [64, 2]})").find("denoise_decoder_channels") != std::string::npos);
  CHECK(err(R"({"skeleton": "paw"})").find("skeleton") != std::string::npos);
  CHECK(err("[1,").find("cfg.json") != std::string::npos);
  CHECK(err(R"({"rate_hz": 4444e4444444})").find("cfg.json") != std::string::npos);  // found by the fuzzer
  // The DGN family: its own keys, none of Multi-STGAE's attention/gates, a tree skeleton.
  auto d = small_config();
  d.family = hs::StgaeFamily::Dgn;
  d.gates = false;
  d.temporal = hs::DgnTemporal::Lstm;
  d.temporal_layers = 3;
  const auto dback = hs::parse_stgae_config(hs::to_json(d), "d.json");
  CHECK(dback.family == hs::StgaeFamily::Dgn);
  CHECK(dback.temporal == hs::DgnTemporal::Lstm);
  CHECK(dback.temporal_layers == 3);
  CHECK(hs::to_json(c).find("family") == std::string::npos);  // Multi-STGAE files are unchanged
  CHECK(err(R"({"family": "dgn", "gates": true})").find("gates") != std::string::npos);
  CHECK(err(R"({"family": "dgn", "attention": "A"})").find("attention") != std::string::npos);
  CHECK(err(R"({"temporal": "lstm"})").find("dgn family only") != std::string::npos);
  CHECK(err(R"({"family": "gcn"})").find("family") != std::string::npos);
  CHECK(err(R"({"family": "dgn", "temporal": "gru"})").find("temporal") != std::string::npos);
  CHECK(err(R"({"family": "dgn", "padding": "centred", "temporal": "lstm", "encoder_channels": [6, 7],
              "denoise_decoder_channels": [7, 3], "predict_decoder_channels": [7, 3]})")
            .find("even") != std::string::npos);
}

TEST_CASE("tensor specs: unique names, shapes following the configuration") {
  auto c = small_config();
  const auto specs = hs::stgae_tensor_specs(c);
  std::set<std::string> names;
  for (const auto& s : specs) CHECK(names.insert(s.name).second);
  auto shape = [&](const std::string& n) {
    for (const auto& s : specs)
      if (s.name == n) return s.shape;
    FAIL("missing " << n);
    return std::vector<int>{};
  };
  CHECK(shape("enc.0.gcn.conv.weight") == std::vector<int>{24, 6});
  CHECK(shape("enc.1.B") == std::vector<int>{3, 26, 26});
  CHECK(shape("enc.1.att.q.weight") == std::vector<int>{12, 8});
  CHECK(shape("den.1.tcn.conv.weight") == std::vector<int>{3, 3, 3});
  CHECK(shape("pre.lift.weight") == std::vector<int>{16, 8});
  CHECK(shape("enc_gate.shared.conv.weight") == std::vector<int>{4, 8});
  CHECK(shape("pre.1.tcn.conv.weight") == std::vector<int>{3, 3, 1});  // causal head: kernel 1
  c.padding = hs::StgaePadding::Centred;
  c.c_variant = hs::StgaeCVariant::Gat;
  const auto centred = hs::stgae_tensor_specs(c);
  bool head = false;
  for (const auto& s : centred) {
    if (s.name == "pre.head.tcn.conv.weight") head = s.shape == std::vector<int>{8, 8, 3};  // T - DT + 1
    CHECK(s.name != "pre.lift.weight");
    if (s.name == "enc.0.att.a") CHECK(s.shape == std::vector<int>{3, 6});
  }
  CHECK(head);
  c.attention = hs::StgaeAttention::A;
  c.gates = false;
  c.predict = false;
  for (const auto& s : hs::stgae_tensor_specs(c)) {
    CHECK(s.name.find(".B") == std::string::npos);
    CHECK(s.name.rfind("pre", 0) != 0);
    CHECK(s.name.find("gate") == std::string::npos);
  }
}

TEST_CASE(".hsm round trip (file) reproduces config, weights and reference") {
  for (auto pad : {hs::StgaePadding::Causal, hs::StgaePadding::Centred}) {
    auto c = small_config();
    c.padding = pad;
    const auto w = hs::random_stgae_weights(c, 4);
    const auto ref = hs::make_stgae_reference(c, w, hs::synthetic_hand_input(c, c.window, 4));
    const auto path = hs::test::temp_dir("stgae_model") / "m.hsm";
    hs::save_hsm(path, c, w, ref);
    const auto m = hs::load_hsm(path);
    CHECK(hs::to_json(m->config) == hs::to_json(c));
    CHECK(m->weights.tensors.size() == w.tensors.size());
    for (const auto& [name, t] : w.tensors) {
      CHECK(m->weights.at(name).shape == t.shape);
      CHECK(m->weights.at(name).data == t.data);
    }
    CHECK(m->reference.denoised == ref.denoised);
    CHECK(m->reference.predicted == ref.predicted);
    REQUIRE(m->net);
    // Serialising the loaded model gives the same bytes.
    CHECK(hs::serialize_hsm(m->config, m->weights, m->reference) == hs::serialize_hsm(c, w, ref));
    std::filesystem::remove_all(path.parent_path());
  }
  CHECK_THROWS_AS(hs::load_hsm("/nonexistent/m.hsm"), hs::InputError);
}

TEST_CASE("the format reads a file without running the engine, loading verifies the reference") {
  const auto c = small_config();
  const auto w = hs::random_stgae_weights(c, 5);
  auto ref = hs::make_stgae_reference(c, w, hs::synthetic_hand_input(c, c.window, 5));
  ref.denoised[3] += 0.5f;  // well formed, but not what the net computes
  const auto bytes = hs::serialize_hsm(c, w, ref);
  const hs::HsmContents got = hs::read_hsm(bytes, "model.hsm");
  CHECK(hs::to_json(got.config) == hs::to_json(c));
  CHECK(got.reference.denoised == ref.denoised);
  CHECK(hs::serialize_hsm(got.config, got.weights, got.reference) == bytes);
  CHECK_THROWS_WITH_AS(hs::parse_hsm(bytes, "model.hsm"), doctest::Contains("reference"), hs::InputError);
  CHECK_NOTHROW(hs::parse_hsm(bytes, "model.hsm", /*verify=*/false));
}

TEST_CASE(".hsm loader: every defect is an InputError naming the problem") {
  const auto c = small_config();
  const auto good = small_file(c);
  REQUIRE(load_error(good).empty());

  auto bad = good;
  bad[0] = 'X';
  CHECK(load_error(bad).find("bad magic") != std::string::npos);

  bad = good;
  bad[8] = 2;
  reseal(bad);
  CHECK(load_error(bad).find("version 2") != std::string::npos);

  bad = good;
  bad[good.size() / 2] ^= 0x40;
  CHECK(load_error(bad).find("checksum") != std::string::npos);

  // Truncated at many offsets (with and without a matching checksum): never a crash.
  for (size_t len = 0; len < good.size(); len += 1 + len / 16) {
    std::vector<std::uint8_t> t(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(len));
    CHECK_FALSE(load_error(t).empty());
    if (t.size() >= 20) {
      reseal(t);
      const auto e = load_error(t);
      CHECK_FALSE(e.empty());
    }
  }

  // A wrong shape, correctly checksummed: named with expected and actual shape.
  bad = good;
  const std::string name = "enc.1.res.conv.bias";
  const size_t at = find_bytes(bad, name) + name.size();  // then dtype, ndim, dims
  REQUIRE(bad[at + 1] == 1);
  bad[at + 2] = 9;  // [8] -> [9]
  reseal(bad);
  const auto e = load_error(bad);
  CHECK(e.find(name) != std::string::npos);
  CHECK(e.find("expected [8], got [9]") != std::string::npos);

  // A tensor name that does not belong to the configuration.
  bad = good;
  bad[find_bytes(bad, "enc.1.res.conv.bias")] = 'x';
  reseal(bad);
  CHECK(load_error(bad).find("unexpected tensor") != std::string::npos);

  // A weight that no longer reproduces the reference output.
  bad = good;
  {
    const size_t p = find_bytes(bad, "den.1.res.conv.bias") + std::string("den.1.res.conv.bias").size() + 2 + 4;
    bad[p + 3] ^= 0x20;  // flips an exponent bit of the first bias value
  }
  reseal(bad);
  CHECK(load_error(bad).find("reference") != std::string::npos);

  // A reference output changed, checksum fixed: the verification catches it.
  bad = good;
  bad[bad.size() - 8 - 4 * 10 + 2] ^= 0x7f;
  reseal(bad);
  CHECK(load_error(bad).find("does not reproduce its reference") != std::string::npos);

  // Trailing bytes before the checksum.
  bad = good;
  bad.insert(bad.end() - 8, 0);
  reseal(bad);
  CHECK(load_error(bad).find("unexpected bytes") != std::string::npos);

  // A configuration that does not parse.
  bad = good;
  bad[find_bytes(bad, "\"window\"") + 1] = 'W';
  reseal(bad);
  CHECK(load_error(bad).find("Window") != std::string::npos);

  // Every single-bit corruption is detected.
  for (size_t i = 0; i < good.size(); i += 7) {
    bad = good;
    bad[i] ^= 0x01;
    CHECK_FALSE(load_error(bad).empty());
  }
}

TEST_CASE("weights checks: missing, unexpected, wrong shape, negative variance") {
  const auto c = small_config();
  auto w = hs::random_stgae_weights(c, 2);
  CHECK_NOTHROW(hs::check_stgae_weights(c, w));
  auto m = w;
  m.tensors.erase("enc.0.B");
  CHECK_THROWS_WITH_AS(hs::check_stgae_weights(c, m), doctest::Contains("enc.0.B"), hs::InputError);
  m = w;
  m.tensors["extra"] = hs::Tensor{{1}, {0.0f}};
  CHECK_THROWS_AS(hs::check_stgae_weights(c, m), hs::InputError);
  m = w;
  m.tensors.at("enc.0.tcn.bn.running_var").data[0] = -1.0f;
  CHECK_THROWS_WITH_AS(hs::check_stgae_weights(c, m), doctest::Contains("variance"), hs::InputError);
  m = w;
  m.tensors.at("enc.0.gcn.conv.weight").shape = {6, 24};
  CHECK_THROWS_AS(hs::check_stgae_weights(c, m), hs::InputError);
  // make_stgae_model verifies a reference computed elsewhere.
  auto ref = hs::make_stgae_reference(c, w, hs::synthetic_hand_input(c, c.window, 2));
  CHECK_NOTHROW(hs::make_stgae_model(c, w, ref));
  ref.denoised[5] += 0.01f;
  CHECK_THROWS_AS(hs::make_stgae_model(c, w, ref), hs::InputError);
}

TEST_CASE("the models shipped in models/ load (checksum and reference pair verified) with their card's configuration") {
  const auto dir = hs::test::models_dir();
  // The causal model the layer and the CLI use by default (models/MODEL.md).
  const auto causal = hs::load_hsm(dir / "handsteady_xr26_causal.hsm");
  CHECK(causal->config.padding == hs::StgaePadding::Causal);
  CHECK(causal->config.window == 16);
  CHECK(causal->config.joint_count() == hs::kJointCount);
  // The centred published-structure model for window mode (models/MODEL.md "Centred").
  const auto centred = hs::load_hsm(dir / "handsteady_xr26_centred.hsm");
  const hs::StgaeConfig& c = centred->config;
  CHECK(c.padding == hs::StgaePadding::Centred);
  CHECK(c.window == 36);
  CHECK(c.horizon == 5);
  CHECK(c.temporal_kernel == 9);
  CHECK(c.attention == hs::StgaeAttention::ABC);
  CHECK(c.gates);
  CHECK(c.predict);
  const std::vector<float> in = hs::synthetic_hand_input(c, c.window, 3);
  const hs::StgaeFrames<float> frames =
      Eigen::Map<const hs::StgaeFrames<float>>(in.data(), c.window, 3 * c.joint_count());
  const auto y = hs::stgae_window_forward(*centred->net, frames);
  CHECK(y.denoised.allFinite());
  CHECK(y.predicted.rows() == 5);
  // The denoise-only STGAE and the DGN (models/MODEL.md "STGAE", "DGN").
  const auto stgae = hs::load_hsm(dir / "handsteady_xr26_stgae.hsm");
  CHECK(stgae->config.family == hs::StgaeFamily::MultiStgae);
  CHECK_FALSE(stgae->config.predict);
  CHECK_FALSE(stgae->config.gates);
  const auto dgn = hs::load_hsm(dir / "handsteady_xr26_dgn.hsm");
  CHECK(dgn->config.family == hs::StgaeFamily::Dgn);
  CHECK(dgn->config.padding == hs::StgaePadding::Causal);
  CHECK(dgn->config.temporal == hs::DgnTemporal::Tcn);
  CHECK(dgn->config.encoder_channels == std::vector<int>{6, 24, 32});
  CHECK(std::filesystem::file_size(dir / "handsteady_xr26_dgn.hsm") <= 5u * 1024 * 1024);
}

TEST_CASE("blend: each tensor (1 - alpha) a + alpha b, the ends are the models themselves, the reference recomputed") {
  const auto c = small_config();
  const auto a = small_model(c, 1), b = small_model(c, 2);
  for (const double alpha : {0.0, 0.3, 1.0}) {
    CAPTURE(alpha);
    const auto m = hs::blend_models(a, "a.hsm", b, "b.hsm", alpha);
    REQUIRE(m.weights.tensors.size() == b.weights.tensors.size());
    for (const auto& [name, t] : m.weights.tensors) {
      CAPTURE(name);
      const auto& ta = a.weights.at(name).data;
      const auto& tb = b.weights.at(name).data;
      REQUIRE(t.shape == b.weights.at(name).shape);
      for (size_t i = 0; i < t.data.size(); ++i)
        CHECK(static_cast<double>(t.data[i]) == doctest::Approx((1 - alpha) * static_cast<double>(ta[i]) + alpha * static_cast<double>(tb[i])).epsilon(1e-6));
    }
    // The reference is the blended net's answer to b's reference input.
    CHECK(m.reference.input == b.reference.input);
    const auto expect = hs::make_stgae_reference(m.config, m.weights, b.reference.input);
    CHECK(m.reference.denoised == expect.denoised);
    CHECK(m.reference.predicted == expect.predicted);
    if (alpha == 1.0) CHECK(m.reference.denoised == b.reference.denoised);
    // Runnable and verified, and the meta says where it came from.
    const auto model = hs::make_stgae_model(m.config, m.weights, m.reference, true, "blend");
    REQUIRE(model);
    const auto meta = nlohmann::json::parse(m.config.meta_json);
    CHECK(meta["blend"]["from"] == "a.hsm");
    CHECK(meta["blend"]["to"] == "b.hsm");
    CHECK(meta["blend"]["alpha"] == alpha);
    CHECK(meta["blend"]["to_meta"]["seed"] == 2);
    CHECK(meta["blend"]["from_meta"]["seed"] == 1);
  }
  // Halfway, the blend differs from both.
  const auto h = hs::blend_models(a, "a.hsm", b, "b.hsm", 0.5);
  CHECK(h.reference.denoised != a.reference.denoised);
  CHECK(h.reference.denoised != b.reference.denoised);
}

TEST_CASE("blend: another network or a weight outside [0, 1] is an InputError naming it") {
  const auto c = small_config();
  const auto a = small_model(c, 1);
  auto other = c;
  other.encoder_channels = {6, 8, 16};
  other.denoise_decoder_channels = {16, 4, 3};
  other.predict_decoder_channels = {16, 4, 3};
  const auto b = small_model(other, 2);
  const auto e = blend_error(a, b, 0.5);
  CHECK(e.find("b.hsm") != std::string::npos);
  CHECK(e.find("config") != std::string::npos);
  CHECK(e.find("a.hsm") != std::string::npos);
  auto centred = c;
  centred.padding = hs::StgaePadding::Centred;
  CHECK(blend_error(a, small_model(centred, 2), 0.5).find("config") != std::string::npos);
  for (const double alpha : {-0.1, 1.5, std::nan("")}) CHECK(blend_error(a, small_model(c, 2), alpha).find("alpha") != std::string::npos);
  // Only the meta may differ.
  CHECK(blend_error(a, small_model(c, 3), 0.5).empty());
}

TEST_CASE("handsteady blend writes a model that loads and verifies, and refuses bad input with status 2") {
  const auto dir = hs::test::temp_dir("blend");
  const auto c = small_config();
  const auto a = small_model(c, 1), b = small_model(c, 2);
  hs::save_hsm(dir / "a.hsm", a.config, a.weights, a.reference);
  hs::save_hsm(dir / "b.hsm", b.config, b.weights, b.reference);
  const auto q = [](const std::filesystem::path& p) { return "\"" + p.string() + "\""; };
  REQUIRE(hs::test::run_cli("blend --from " + q(dir / "a.hsm") + " --to " + q(dir / "b.hsm") + " --alpha 0.25 --out " +
                            q(dir / "ab.hsm") + " > " + q(dir / "log")) == 0);
  const auto m = hs::load_hsm(dir / "ab.hsm", true);
  const auto expect = hs::blend_models(a, (dir / "a.hsm").string(), b, (dir / "b.hsm").string(), 0.25);
  for (const auto& [name, t] : expect.weights.tensors) CHECK(m->weights.at(name).data == t.data);
  CHECK(m->config.meta_json == expect.config.meta_json);
  CHECK(!std::filesystem::exists(dir / "ab.hsm.tmp"));

  auto other = c;
  other.temporal_kernel = 5;
  const auto o = small_model(other, 3);
  hs::save_hsm(dir / "o.hsm", o.config, o.weights, o.reference);
  CHECK(hs::test::run_cli("blend --from " + q(dir / "a.hsm") + " --to " + q(dir / "o.hsm") + " --alpha 0.5 --out " +
                          q(dir / "x.hsm") + " 2> " + q(dir / "err")) == 2);
  std::ifstream in(dir / "err");
  std::stringstream ss;
  ss << in.rdbuf();
  CHECK(ss.str().find("o.hsm") != std::string::npos);
  CHECK(!std::filesystem::exists(dir / "x.hsm"));
  CHECK(hs::test::run_cli("blend --from " + q(dir / "a.hsm") + " --to " + q(dir / "b.hsm") + " --alpha 1.5 --out " +
                          q(dir / "x.hsm") + " 2> " + q(dir / "err")) != 0);
  CHECK(!std::filesystem::exists(dir / "x.hsm"));
}

TEST_CASE("the shipped causal, STGAE and DGN models are 0.3 x their base + 0.7 x their fine-tune (models/MODEL.md, models/base)") {
  const auto dir = hs::test::models_dir();
  // Each model's steps are named in models/MODEL.md's tables: since the evening of 2026-11-29 the causal
  // model's base is the `_long_` one (the full schedule) and since the night of 2026-11-30 its fine-tune
  // the `_newest_` one (loss.newest); STGAE's pair is `_long_` since 2026-11-30; the other files in
  // models/base are the steps of the models shipped before.
  struct Steps {
    std::string name, base, finetune;
  };
  const std::array<Steps, 3> models{{{"causal", "_long", "_newest"}, {"stgae", "_long", "_long"}, {"dgn", "", ""}}};
  for (const auto& model : models) {
    const auto& name = model.name;
    CAPTURE(name);
    const auto stem = "handsteady_xr26_" + name;
    const auto base_file = stem + model.base + "_base.hsm";
    const auto finetune_file = stem + model.finetune + "_finetune.hsm";
    const auto base = hs::read_hsm_file(dir / "base" / base_file);
    const auto finetune = hs::read_hsm_file(dir / "base" / finetune_file);
    const auto shipped = hs::read_hsm_file(dir / (stem + ".hsm"));
    const auto blend = hs::blend_models(base, "base", finetune, "finetune", 0.7);
    REQUIRE(shipped.weights.tensors.size() == blend.weights.tensors.size());
    for (const auto& [tensor, t] : blend.weights.tensors) {
      CAPTURE(tensor);
      CHECK(shipped.weights.at(tensor).data == t.data);
    }
    CHECK(nlohmann::json::parse(shipped.config.meta_json)["blend"]["alpha"] == 0.7);
    // Both steps are loadable models themselves (checksum and reference verified).
    CHECK(hs::load_hsm(dir / "base" / base_file));
    CHECK(hs::load_hsm(dir / "base" / finetune_file));
  }
}

// A model's meta keeps its training record (configs, the files it started from); a path of
// the machine it was trained on would travel with every installed copy (package_deb looks
// for the checkout's own path in the package, so it sees this only in a checkout at that
// path). Paths are named from the checkout's root (scripts/train_shipped_model.sh).
TEST_CASE("the models in models/ name no absolute path in their meta") {
  const auto dir = hs::test::models_dir();
  std::vector<std::string> hits;
  auto walk = [&hits](const nlohmann::json& j, const std::string& where, auto& self) -> void {
    if (j.is_object()) {
      for (const auto& [k, v] : j.items()) self(v, where + "." + k, self);
    } else if (j.is_array()) {
      for (size_t i = 0; i < j.size(); ++i) self(j[i], where + "[" + std::to_string(i) + "]", self);
    } else if (j.is_string()) {
      const auto s = j.get<std::string>();
      if (!s.empty() && (s.front() == '/' || s.find(":\\") != std::string::npos)) hits.push_back(where + " = " + s);
    }
  };
  size_t files = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (e.path().extension() != ".hsm") continue;
    ++files;
    const auto meta = nlohmann::json::parse(hs::read_hsm_file(e.path()).config.meta_json);
    walk(meta, e.path().lexically_relative(dir).string(), walk);
  }
  CHECK(files >= 8);
  CAPTURE(hits.size());
  for (const auto& h : hits) MESSAGE(h);
  CHECK(hits.empty());
}
