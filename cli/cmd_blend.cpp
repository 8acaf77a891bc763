// `handsteady blend`: a model between two models of one network, (1 - alpha) * from +
// alpha * to in weight space (hs::blend_models): a fine-tune blended back towards the model
// it started from (docs/TRAINING.md "Blending a fine-tune with its start").
#include "commands.hpp"

#include "handsteady/model_blend.hpp"
#include "handsteady/stgae_model.hpp"

#include <fmt/format.h>

#include <memory>
#include <string>

namespace hs::cli {
namespace {

struct BlendOptions {
  std::string from, to, out;
  double alpha = 0.5;
};

void setup_blend(CLI::App& app) {
  auto o = std::make_shared<BlendOptions>();
  auto* sub = app.add_subcommand("blend", "Interpolate two models of one network in weight space: (1 - alpha) * from + alpha * to");
  sub->add_option("--from", o->from, "Model the blend starts from (alpha 0), e.g. the model a fine-tune started from")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--to", o->to, "Model the blend goes to (alpha 1), e.g. the fine-tune")->required()->check(CLI::ExistingFile);
  sub->add_option("--alpha", o->alpha, "Weight of --to, in [0, 1]")->required()->check(CLI::Range(0.0, 1.0));
  sub->add_option("--out", o->out, "Output .hsm")->required();
  sub->callback([o] {
    const auto from = read_hsm_file(o->from);
    const auto to = read_hsm_file(o->to);
    const auto out = blend_models(from, o->from, to, o->to, o->alpha);
    save_hsm_verified(o->out, out.config, out.weights, out.reference);
    fmt::print("blend: {:g} x {} + {:g} x {} -> {}\n", 1.0 - o->alpha, o->from, o->alpha, o->to, o->out);
  });
}

const CommandRegistration register_blend(&setup_blend);

}  // namespace
}  // namespace hs::cli
