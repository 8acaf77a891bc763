#include "hand_tuning.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace hs::layer {

HandTuning::HandTuning(const LayerConfig& config, std::function<void(const std::string&, bool)> report)
    : max_horizon_ns_(config.max_horizon_ns), report_(std::move(report)) {
  set(config.hands);
  const char* path = std::getenv("HANDSTEADY_CONFIG");
  if (!path || !*path) return;  // nothing that can change
  file_ = path;
  // What the configuration was read from: changes are judged against it, however late the
  // watcher thread starts.
  seen_ = read_file();
  watcher_ = std::thread([this] { watch(); });
}

HandTuning::~HandTuning() {
  if (!watcher_.joinable()) return;
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  watcher_.join();
}

void HandTuning::set(const std::array<HandSettings, 2>& hands) noexcept {
  for (int h = 0; h < 2; ++h) {
    smoothing_[h].store(hands[h].smoothing, std::memory_order_relaxed);
    horizon_ns_[h].store(std::clamp<int64_t>(hands[h].horizon_ns, 0, max_horizon_ns_), std::memory_order_relaxed);
  }
}

std::string HandTuning::read_file() const {
  std::ifstream in(file_, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return in ? text.str() : std::string();
}

void HandTuning::watch() noexcept {
  try {
    // The whole (small) file is compared: time stamps are too coarse for quick edits.
    std::string& seen = seen_;
    std::unique_lock lock(mu_);
    while (!cv_.wait_for(lock, std::chrono::milliseconds(kPollMs), [&] { return stop_; })) {
      std::string now = read_file();
      if (now == seen || now.empty()) continue;  // unchanged, or being replaced
      seen = std::move(now);
      std::vector<std::string> warnings;
      const auto hands = load_hand_settings(warnings);
      for (const auto& w : warnings) report_(w, true);
      set(hands);
      ++reloads_;
      report_("configuration re-read: smoothing left " + std::to_string(smoothing(0)) + ", right " +
                  std::to_string(smoothing(1)) + "; horizon left " + std::to_string(horizon_ns(0) / 1'000'000) +
                  " ms, right " + std::to_string(horizon_ns(1) / 1'000'000) + " ms",
              false);
    }
  } catch (...) {
    // Out of memory while reading: the values in force stay; no more re-reads.
  }
}

}  // namespace hs::layer
