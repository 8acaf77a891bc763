// Weight-space blending of two models of one network (hs::blend_models) and
// `handsteady blend`.
#include "handsteady/model_blend.hpp"

#include "handsteady/stgae_engine.hpp"
#include "test_support.hpp"

#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>

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
