#pragma once
// Per-hand smoothing and prediction horizon, tunable while the app runs: a watcher thread
// re-reads the configuration file (HANDSTEADY_CONFIG) when it changes (polled every
// kPollMs) and publishes the values through atomics, so the app's thread only loads two
// numbers. Other settings (mode, engine, model) stay as they were at instance creation.
#include "layer_config.hpp"

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace hs::layer {

class HandTuning {
 public:
  static constexpr int kPollMs = 200;

  // warn: called from the watcher thread for each ignored value of a re-read file.
  HandTuning(const LayerConfig& config, std::function<void(const std::string&)> warn);
  ~HandTuning();
  HandTuning(const HandTuning&) = delete;
  HandTuning& operator=(const HandTuning&) = delete;

  // hand: 0 left, 1 right. The horizon is clamped to the configured max_horizon_ns.
  double smoothing(int hand) const noexcept { return smoothing_[hand].load(std::memory_order_relaxed); }
  int64_t horizon_ns(int hand) const noexcept { return horizon_ns_[hand].load(std::memory_order_relaxed); }
  // Number of times new values were taken from the file (tests wait on it).
  int reloads() const noexcept { return reloads_.load(); }

 private:
  void set(const std::array<HandSettings, 2>& hands) noexcept;
  void watch() noexcept;

  const int64_t max_horizon_ns_;
  std::array<std::atomic<double>, 2> smoothing_{};
  std::array<std::atomic<int64_t>, 2> horizon_ns_{};
  std::atomic<int> reloads_{0};
  std::function<void(const std::string&)> warn_;
  std::filesystem::path file_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread watcher_;
};

}  // namespace hs::layer
