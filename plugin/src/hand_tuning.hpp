#pragma once
// Per-hand smoothing and prediction horizon, tunable while the app runs: a watcher thread
// re-reads the configuration file (HANDSTEADY_CONFIG) when its content changes (polled
// every kPollMs) and publishes the values through atomics, so the app's thread only loads two
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

  // report: called from the watcher thread with what was re-read, and for each ignored value
  // (second argument true: a warning).
  HandTuning(const LayerConfig& config, std::function<void(const std::string&, bool)> report);
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
  std::string read_file() const;  // empty when unreadable

  const int64_t max_horizon_ns_;
  std::array<std::atomic<double>, 2> smoothing_{};
  std::array<std::atomic<int64_t>, 2> horizon_ns_{};
  std::atomic<int> reloads_{0};
  std::function<void(const std::string&, bool)> report_;
  std::filesystem::path file_;
  std::string seen_;  // the file's content last applied (watcher thread after construction)
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread watcher_;
};

}  // namespace hs::layer
