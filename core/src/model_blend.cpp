#include "handsteady/model_blend.hpp"

#include "handsteady/error.hpp"

#include <nlohmann/json.hpp>

namespace hs {

HsmContents blend_models(const HsmContents& from, const std::string& from_source, const HsmContents& to,
                         const std::string& to_source, double alpha) {
  if (!(alpha >= 0.0 && alpha <= 1.0))
    throw InputError(SourceLocation{"", 0, "alpha"}, "the blend weight must be in [0, 1], got " + std::to_string(alpha));
  if (!same_network(from.config, to.config))
    throw InputError(SourceLocation{to_source, 0, "config"},
                     "the network configuration differs from " + from_source + "'s: only two models of one network blend");
  check_stgae_weights(from.config, from.weights, from_source);
  check_stgae_weights(to.config, to.weights, to_source);

  HsmContents out;
  out.config = to.config;
  for (const auto& [name, t] : to.weights.tensors) {
    const Tensor& f = from.weights.at(name);
    Tensor r = t;
    for (size_t i = 0; i < r.data.size(); ++i)
      r.data[i] = static_cast<float>((1.0 - alpha) * static_cast<double>(f.data[i]) + alpha * static_cast<double>(t.data[i]));
    out.weights.tensors.emplace(name, std::move(r));
  }
  const auto meta = [](const StgaeConfig& c) {
    auto j = nlohmann::json::parse(c.meta_json.empty() ? std::string("{}") : c.meta_json, nullptr, false);
    return j.is_discarded() ? nlohmann::json(c.meta_json) : j;  // kept as text when not JSON
  };
  out.config.meta_json = nlohmann::json{{"blend",
                                         {{"from", from_source},
                                          {"to", to_source},
                                          {"alpha", alpha},
                                          {"from_meta", meta(from.config)},
                                          {"to_meta", meta(to.config)}}}}
                             .dump();
  out.reference = make_stgae_reference(out.config, out.weights, to.reference.input);
  return out;
}

}  // namespace hs
