// A runnable model: configuration + weights + reference (from memory or an .hsm file),
// the engine's float net, and the check that the net reproduces the reference.
#include "handsteady/hsm_format.hpp"
#include "handsteady/stgae_engine.hpp"
#include "handsteady/stgae_model.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hs {

StgaeReference make_stgae_reference(const StgaeConfig& config, const StgaeWeights& weights, std::vector<float> input) {
  const int N = config.joint_count();
  const auto net = make_stgae_net<double>(config, weights);
  const Eigen::Index cols = 3 * N;
  if (input.size() % static_cast<size_t>(cols) != 0 || input.empty())
    throw std::invalid_argument("make_stgae_reference: input size is not a multiple of 3N");
  const Eigen::Index L = static_cast<Eigen::Index>(input.size()) / cols;
  StgaeFrames<double> x(L, cols);
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = static_cast<double>(input[static_cast<size_t>(i)]);
  const auto y = stgae_window_forward(*net, x);
  StgaeReference r;
  r.frames = static_cast<int>(L);
  r.input = std::move(input);
  r.denoised.resize(static_cast<size_t>(y.denoised.size()));
  for (Eigen::Index i = 0; i < y.denoised.size(); ++i) r.denoised[static_cast<size_t>(i)] = static_cast<float>(y.denoised.data()[i]);
  r.predicted.resize(static_cast<size_t>(y.predicted.size()));
  for (Eigen::Index i = 0; i < y.predicted.size(); ++i) r.predicted[static_cast<size_t>(i)] = static_cast<float>(y.predicted.data()[i]);
  return r;
}

namespace {

void verify_reference(const StgaeModel& m, const std::string& source) {
  const int N = m.config.joint_count();
  const Eigen::Index cols = 3 * N;
  StgaeFrames<float> x(m.reference.frames, cols);
  std::copy(m.reference.input.begin(), m.reference.input.end(), x.data());
  StgaeOutput<float> y;
  try {
    y = stgae_window_forward(*m.net, x);
  } catch (const InputError& e) {
    throw InputError(SourceLocation{source, 0, "reference"}, std::string("reference input rejected: ") + e.what());
  }
  auto compare = [&](const std::vector<float>& expected, const StgaeFrames<float>& got, const char* what) {
    for (Eigen::Index i = 0; i < got.size(); ++i) {
      const auto e = static_cast<double>(expected[static_cast<size_t>(i)]);
      const auto g = static_cast<double>(got.data()[i]);
      if (!(std::abs(e - g) <= 1e-4 * std::max(1.0, std::abs(e))))
        throw InputError(SourceLocation{source, 0, "reference"},
                         std::string("the model does not reproduce its reference ") + what + " output: value " +
                             std::to_string(i) + " (frame " + std::to_string(i / cols) + ", joint " +
                             std::to_string((i % cols) / 3) + ") is " + std::to_string(g) + ", expected " +
                             std::to_string(e) + " (tolerance 1e-4 relative)");
    }
  };
  compare(m.reference.denoised, y.denoised, "denoised");
  if (m.config.predict) compare(m.reference.predicted, y.predicted, "predicted");
}

// Contents already checked by the format (or by make_stgae_model).
std::shared_ptr<const StgaeModel> assemble(HsmContents&& contents, bool verify, const std::string& source) {
  auto m = std::make_shared<StgaeModel>();
  m->config = std::move(contents.config);
  m->weights = std::move(contents.weights);
  m->reference = std::move(contents.reference);
  m->net = make_stgae_net<float>(m->config, m->weights);
  if (verify) verify_reference(*m, source);
  return m;
}

}  // namespace

std::shared_ptr<const StgaeModel> make_stgae_model(StgaeConfig config, StgaeWeights weights, StgaeReference reference,
                                                   bool verify, const std::string& source) {
  validate_stgae_config(config, source);
  check_stgae_weights(config, weights, source);
  check_stgae_reference(config, reference, source);
  return assemble(HsmContents{std::move(config), std::move(weights), std::move(reference)}, verify, source);
}

std::shared_ptr<const StgaeModel> parse_hsm(std::span<const std::uint8_t> bytes, const std::string& source, bool verify) {
  return assemble(read_hsm(bytes, source), verify, source);
}

std::shared_ptr<const StgaeModel> load_hsm(const std::filesystem::path& path, bool verify) {
  return assemble(read_hsm_file(path), verify, path.string());
}

void save_hsm_verified(const std::filesystem::path& path, const StgaeConfig& config, const StgaeWeights& weights,
                       const StgaeReference& reference) {
  auto tmp = path;
  tmp += ".tmp";
  save_hsm(tmp, config, weights, reference);
  (void)load_hsm(tmp, true);
  std::filesystem::rename(tmp, path);
}

}  // namespace hs
