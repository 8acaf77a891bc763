#pragma once
// What the demo leaves behind: the joints the app saw (raw and HandSteady) as track
// CSVs, the ink metrics (distance to the font strokes, jerk, latency) as summary.json
// and summary.md, and the trajectory plot of the index fingertip.
#include "handsteady/handwriting.hpp"
#include "handsteady/ink.hpp"
#include "handsteady/track.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace hs::demo {

// One panel's view of the session. Times are track seconds (see main.cpp).
struct PanelRecord {
  std::string name;  // "raw", "handsteady"
  std::string label;
  HandSeries seen;   // right hand as the app received it, per frame
  std::vector<InkStroke> ink;
};

// The index fingertip predicted `horizon_ms` ahead by a Multi-STGAE model run over the raw
// panel's joints after the session (the layer answers the app at the display time only).
struct Prediction {
  double horizon_ms = 0.0;
  std::string model;  // file
  HandSeries at_row;  // estimate for t + horizon, stored at the row time t
};

struct ReportInputs {
  std::vector<PanelRecord> panels;
  std::optional<Prediction> prediction;
  std::optional<StrokeSet> strokes;
  std::optional<HandSeries> truth;  // right hand of the clean track
  std::string layer_mode;           // "denoise", "predict"
};

// Writes <dir>/{raw,handsteady}_seen.csv, summary.json, summary.md and (with truth)
// index_tip_plot.png (with the prediction, when given, at its target times); returns the
// summary text (Markdown).
std::string write_report(const std::filesystem::path& dir, const ReportInputs& in);

}  // namespace hs::demo
