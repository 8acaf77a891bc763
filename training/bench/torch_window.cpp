// libtorch window forward for the benchmark (torch_window.hpp), built the way
// training/tests/test_stgae_parity.cpp builds it: StgaeNetImpl(config), import_weights,
// eval(); features from hs::train::input_features.
#include "torch_window.hpp"

#include "stgae_torch.hpp"
#include "train_data.hpp"

#include <torch/torch.h>
#include <torch/version.h>

#include <stdexcept>
#include <string>

namespace hs::bench {

struct TorchWindow::Impl {
  explicit Impl(const StgaeConfig& c) : net(c) {}
  train::StgaeNetImpl net;
  torch::Tensor features, filled, denoised, predicted;
};

TorchWindow::TorchWindow(const StgaeModel& model, const std::vector<Pose>& raw) {
  torch::set_num_threads(1);
  try {
    torch::set_num_interop_threads(1);
  } catch (const std::exception&) {
    // Already set (it can be set once per process); one inter-op thread is the default use.
  }
  impl_ = std::make_unique<Impl>(model.config);
  train::import_weights(impl_->net, model.weights);
  impl_->net.eval();
  const auto L = static_cast<int64_t>(raw.size());
  const int n = kJointCount;
  std::vector<double> feat(static_cast<size_t>(L) * n * 6), filled(static_cast<size_t>(L) * n * 3);
  if (!train::input_features(raw, model.config.shape_scale_m, model.config.velocity_scale_m, feat.data(),
                             filled.data()))
    throw std::runtime_error("TorchWindow: the first frame has no tracked joint");
  impl_->features = torch::from_blob(feat.data(), {1, L, n, 6}, torch::kFloat64).to(torch::kFloat32);
  impl_->filled = torch::from_blob(filled.data(), {1, L, n, 3}, torch::kFloat64).to(torch::kFloat32);
}

TorchWindow::~TorchWindow() = default;

void TorchWindow::forward() {
  torch::NoGradGuard no_grad;
  const auto out = impl_->net.forward(impl_->features);
  impl_->denoised = train::denoised_positions(impl_->net.config, impl_->filled, out);
  if (impl_->net.config.predict) impl_->predicted = train::predicted_positions(impl_->net.config, impl_->denoised, out);
}

namespace {
std::vector<float> to_vector(const torch::Tensor& t) {
  if (!t.defined()) return {};
  const auto c = t.contiguous().to(torch::kFloat32);
  const float* p = c.data_ptr<float>();
  return {p, p + c.numel()};
}
}  // namespace

std::vector<float> TorchWindow::denoised() const { return to_vector(impl_->denoised); }
std::vector<float> TorchWindow::predicted() const { return to_vector(impl_->predicted); }

std::string TorchWindow::describe() {
  return std::string("libtorch ") + TORCH_VERSION + ", " + std::to_string(torch::get_num_threads()) +
         " intra-op thread(s)";
}

}  // namespace hs::bench
