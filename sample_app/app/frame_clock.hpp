#pragma once
// Frame timing for a session whose xrWaitFrame gives no display time: Monado's headless
// session (null compositor) returns at once with predictedDisplayTime 0. Such an app
// paces itself and takes its times from XR_KHR_convert_timespec_time: here a fixed rate
// on CLOCK_MONOTONIC, the clock that extension converts.
#define XR_USE_TIMESPEC
#include <time.h>

#include <openxr/openxr.h>
#include <openxr/openxr_platform.h>

namespace hs::demo {

class FrameClock {
 public:
  // Throws std::invalid_argument unless 1 <= fps <= 1e6 and convert is set.
  FrameClock(XrInstance instance, PFN_xrConvertTimespecTimeToTimeKHR convert, double fps);

  // Sleeps to the next frame boundary (never spins; after a stall it goes on from now
  // instead of rushing through the missed frames) and returns the XrTime of now + one
  // period: the frame drawn now is seen at the next refresh. Throws std::runtime_error
  // when the conversion fails.
  XrTime next();

 private:
  XrInstance instance_;
  PFN_xrConvertTimespecTimeToTimeKHR convert_;
  int64_t period_ns_;
  int64_t deadline_ns_ = 0;  // CLOCK_MONOTONIC of the next frame; 0 before the first
};

}  // namespace hs::demo
