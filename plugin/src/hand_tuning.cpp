#include "hand_tuning.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <system_error>

namespace hs::layer {

HandTuning::HandTuning(const LayerConfig& config, std::function<void(const std::string&)> warn)
    : max_horizon_ns_(config.max_horizon_ns), warn_(std::move(warn)) {
  set(config.hands);
  const char* path = std::getenv("HANDSTEADY_CONFIG");
  if (!path || !*path) return;  // nothing that can change
  file_ = path;
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

void HandTuning::watch() noexcept {
  std::error_code ec;
  auto stamp = std::filesystem::last_write_time(file_, ec);
  auto size = std::filesystem::file_size(file_, ec);
  std::unique_lock lock(mu_);
  while (!cv_.wait_for(lock, std::chrono::milliseconds(kPollMs), [&] { return stop_; })) {
    // Size too: two writes within the file system's time resolution still differ in size
    // more often than not.
    const auto now = std::filesystem::last_write_time(file_, ec);
    if (ec) continue;  // being replaced: try again at the next poll
    const auto now_size = std::filesystem::file_size(file_, ec);
    if (ec || (now == stamp && now_size == size)) continue;
    stamp = now;
    size = now_size;
    try {
      std::vector<std::string> warnings;
      const auto hands = load_hand_settings(warnings);
      for (const auto& w : warnings) warn_(w);
      set(hands);
      ++reloads_;
    } catch (...) {
      // Out of memory while parsing: keep the values in force.
    }
  }
}

}  // namespace hs::layer
