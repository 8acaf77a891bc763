#include "frame_clock.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <stdexcept>

namespace hs::demo {
namespace {

constexpr int64_t kNsPerSecond = 1'000'000'000;

int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

timespec to_timespec(int64_t ns) {
  return {static_cast<time_t>(ns / kNsPerSecond), static_cast<long>(ns % kNsPerSecond)};
}

int64_t period_of(double fps) {
  if (!(fps >= 1.0 && fps <= 1e6)) throw std::invalid_argument(fmt::format("FrameClock: bad rate {} Hz", fps));
  return static_cast<int64_t>(1e9 / fps + 0.5);
}

}  // namespace

FrameClock::FrameClock(XrInstance instance, PFN_xrConvertTimespecTimeToTimeKHR convert, double fps)
    : instance_(instance), convert_(convert), period_ns_(period_of(fps)) {
  if (!convert_) throw std::invalid_argument("FrameClock: no xrConvertTimespecTimeToTimeKHR");
}

XrTime FrameClock::next() {
  int64_t now = monotonic_ns();
  if (deadline_ns_ == 0 || now - deadline_ns_ > period_ns_) {
    deadline_ns_ = now;  // the first frame, or late by over a frame: start afresh from now
  } else {
    // Absolute deadlines: the rate does not drift with the time each frame takes.
    const timespec until = to_timespec(deadline_ns_);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) == EINTR) {
    }
    now = monotonic_ns();
  }
  deadline_ns_ += period_ns_;
  const timespec display = to_timespec(now + period_ns_);
  XrTime t = 0;
  const XrResult r = convert_(instance_, &display, &t);
  if (XR_FAILED(r) || t <= 0)
    throw std::runtime_error(
        fmt::format("OpenXR: xrConvertTimespecTimeToTimeKHR gave no time (XrResult {}, time {})", static_cast<int>(r), t));
  return t;
}

}  // namespace hs::demo
