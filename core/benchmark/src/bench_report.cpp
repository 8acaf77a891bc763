// The benchmark's report: markdown tables (with the Multi-STGAE v2 issue's criteria
// checked for every learnt model), JSON with every number, and One Euro's curve as CSV.
#include "handsteady/benchmark.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

namespace hs::bench {
namespace {

// Results by cell key, then method.
using Index = std::map<std::string, std::map<std::string, const Result*>>;
Index index_of(const Report& r) {
  Index ix;
  for (const Result& x : r.results) ix[x.cell.key()][x.method] = &x;
  return ix;
}
const Metrics* at(const Index& ix, const Cell& c, const std::string& method, size_t h) {
  const auto a = ix.find(c.key());
  if (a == ix.end()) return nullptr;
  const auto b = a->second.find(method);
  return b == a->second.end() ? nullptr : &b->second->at[h];
}

// Cells of one block (in report order, each once).
std::vector<Cell> cells_of(const Report& r, const std::string& block) {
  std::vector<Cell> out;
  std::set<std::string> seen;
  for (const Result& x : r.results)
    if (x.cell.block == block && seen.insert(x.cell.key()).second) out.push_back(x.cell);
  return out;
}

std::string num(double v, int decimals) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : "–"; }

std::string header_row(const std::vector<std::string>& first, const std::vector<std::string>& methods) {
  std::string s = "|";
  for (const auto& f : first) s += " " + f + " |";
  for (const auto& m : methods) s += " " + m + " |";
  s += "\n|";
  for (size_t i = 0; i < first.size(); ++i) s += "---|";
  for (size_t i = 0; i < methods.size(); ++i) s += "---:|";
  return s + "\n";
}

using CellText = std::function<std::string(const Metrics&)>;

// One row per cell, one column per method.
std::string table(const Report& r, const Index& ix, const std::vector<Cell>& cells,
                  const std::vector<std::string>& first_cols, const std::function<std::vector<std::string>(const Cell&)>& first,
                  size_t h, const CellText& text) {
  std::string s = header_row(first_cols, r.methods);
  for (const Cell& c : cells) {
    s += "|";
    for (const auto& f : first(c)) s += " " + f + " |";
    for (const auto& m : r.methods) {
      const Metrics* x = at(ix, c, m, h);
      s += " " + (x ? text(*x) : std::string("–")) + " |";
    }
    s += "\n";
  }
  return s + "\n";
}

bool strong_noise(const Cell& c) {
  return (c.family == "white" || c.family == "correlated" || c.family.rfind("tremor-", 0) == 0) && c.level_mm >= 1.5;
}
bool low_noise(const Cell& c) {
  return (c.family == "white" || c.family == "correlated" || c.family.rfind("tremor-", 0) == 0) && c.level_mm < 1.5;
}

// The least jitter a classical method reaches on a recording at lag_ms, on its curve
// (Report::recorded_curves).
double baseline_jitter_at(const Report& r, const Cell& c, const std::string& method, double lag_ms) {
  std::vector<std::pair<double, double>> pts;
  for (const LagPoint& p : r.recorded_curves)
    if (p.cell == c.key() && p.method == method) pts.emplace_back(p.lag_ms, p.jitter_mm);
  return jitter_at_lag(std::move(pts), lag_ms);
}

struct Tally {
  int pass = 0, total = 0;
  double worst = -std::numeric_limits<double>::infinity();
  std::string worst_cell;
  void add(bool ok, double ratio, const std::string& cell) {
    ++total;
    pass += ok ? 1 : 0;
    if (std::isfinite(ratio) && ratio > worst) {
      worst = ratio;
      worst_cell = cell;
    }
  }
  std::string text(const std::string& what) const {
    if (total == 0) return "no cells";
    return fmt::format("{} {}/{} cells{}", pass == total ? "**pass**" : "**fail**", pass, total,
                       std::isfinite(worst) ? fmt::format("; worst {} {:.2f} ({})", what, worst, worst_cell) : "");
  }
};

std::string criteria(const Report& r, const Index& ix) {
  std::string s;
  const auto noise_cells = cells_of(r, "noise");
  for (const auto& model : r.models) {
    Tally den, low, pred, pred_jit, rec, still;
    for (const Cell& c : noise_cells) {
      const Metrics* m = at(ix, c, model, 0);
      const Metrics* oe = at(ix, c, "oneeuro-tuned", 0);
      const Metrics* raw = at(ix, c, "raw", 0);
      const std::string name = c.dataset + " " + c.family + " " + c.strength;
      if (m && oe && strong_noise(c)) {
        const double ratio = m->mpjpe_mm / oe->mpjpe_mm;
        den.add(ratio <= 0.6 && m->lag_ms <= 5.0, ratio, name);
      }
      if (m && raw && low_noise(c)) low.add(m->mpjpe_mm <= raw->mpjpe_mm, m->mpjpe_mm / raw->mpjpe_mm, name);
      const Metrics* m50 = at(ix, c, model, 2);
      const Metrics* k50 = at(ix, c, "kalman", 2);
      const Metrics* d50 = at(ix, c, "desp", 2);
      if (m50 && k50 && d50) {
        const double best = std::min(k50->mpjpe_mm, d50->mpjpe_mm);
        pred.add(m50->mpjpe_mm <= 0.75 * best, m50->mpjpe_mm / best, name);
        const double jr = m50->jitter_mm / m50->truth_jitter_mm;
        pred_jit.add(jr <= 1.5, jr, name);
      }
    }
    for (const Cell& c : cells_of(r, "recorded")) {
      const Metrics* m = at(ix, c, model, 0);
      for (const std::string other : {"oneeuro", "kalman"}) {
        if (!m) continue;
        const double o = baseline_jitter_at(r, c, other, m->lag_ms);
        if (std::isfinite(o))
          rec.add(m->jitter_mm < o, m->jitter_mm / o, fmt::format("{} vs {} at {:.1f} ms", c.dataset, other, m->lag_ms));
      }
    }
    for (const StillResult& x : r.still)
      if (x.method == model) {
        const double worst = std::max({x.start_mm / 1.0, x.resume_mm / 1.0, x.drift_mm / 0.3});
        still.add(x.start_mm <= 1.0 && x.resume_mm <= 1.0 && x.drift_mm <= 0.3, worst, x.dataset + " " + x.shape);
      }
    s += fmt::format("**{}**\n\n", model);
    s += "| criterion | result |\n|---|---|\n";
    s += fmt::format("| denoising, jitter/tremor ≥ 1.5 mm: MPJPE ≤ 0.6 × tuned One Euro, lag ≤ 5 ms | {} |\n", den.text("ratio"));
    s += fmt::format("| denoising, low noise: MPJPE ≤ raw | {} |\n", low.text("ratio to raw"));
    s += fmt::format("| recordings without truth: less jitter than One Euro and Kalman at equal lag (their sweeps) | {} |\n",
                     rec.text("jitter ratio"));
    s += fmt::format("| prediction 50 ms: MPJPE ≤ 0.75 × best of Kalman/DESP | {} |\n", pred.text("ratio"));
    s += fmt::format("| prediction 50 ms: jitter ≤ 1.5 × the truth's | {} |\n", pred_jit.text("ratio"));
    s += fmt::format("| start ≤ 1 mm, resume ≤ 1 mm, still drift ≤ 0.3 mm, every shape | {} |\n\n",
                     still.text("error / limit"));
  }
  if (r.models.empty()) s += "No learnt model was benchmarked (none given or found).\n\n";
  return s;
}

// One row per cell of set, noise and rate; per method the MPJPE at H = 0 (lag ms) · at 50 ms.
std::string rate_table(const Report& r, const Index& ix, const std::vector<Cell>& cells, const std::string& rate_header,
                       int mpjpe_decimals, int lag_decimals) {
  std::string t = header_row({"set", "noise", rate_header}, r.methods);
  for (const Cell& c : cells) {
    t += fmt::format("| {} | {} {} | {:g} |", c.dataset, c.family, c.strength, c.rate_hz);
    for (const auto& m : r.methods) {
      const Metrics* a = at(ix, c, m, 0);
      const Metrics* b = at(ix, c, m, 2);
      t += " " + (a && b ? num(a->mpjpe_mm, mpjpe_decimals) + " (" + num(a->lag_ms, lag_decimals) + ") · " + num(b->mpjpe_mm, 2) : "–") +
           " |";
    }
    t += "\n";
  }
  return t + "\n";
}

// One row per method over every noise cell: mean MPJPE and lag, how often it is the best,
// and the median jitter ratio (a headline; the cells are in the tables below).
std::string summary(const Report& r, const Index& ix) {
  const auto cells = cells_of(r, "noise");
  std::string s = fmt::format(
      "Over the {} noise cells of the {} sets: mean MPJPE (mm), mean lag (ms), mean E_bon (mm²), cells where the "
      "method has the lowest MPJPE, and the median jitter / truth's jitter.\n\n",
      cells.size(), r.tuning_split ? "tuning" : "test");
  s += "| method | H = 0 MPJPE | lag | E_bon | best | jitter ratio | 20 ms MPJPE | 50 ms MPJPE | best at 50 ms | 50 ms jitter ratio |\n"
       "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  std::map<std::string, std::array<int, 2>> best;
  for (const Cell& c : cells)
    for (const size_t h : {size_t{0}, size_t{2}}) {
      std::string who;
      double lo = std::numeric_limits<double>::infinity();
      for (const auto& m : r.methods)
        if (const Metrics* x = at(ix, c, m, h); x && x->mpjpe_mm < lo) {
          lo = x->mpjpe_mm;
          who = m;
        }
      if (!who.empty()) ++best[who][h == 0 ? 0 : 1];
    }
  const auto median = [](std::vector<double> v) {
    if (v.empty()) return kNaN;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  for (const auto& m : r.methods) {
    std::array<double, kHorizonsS.size()> sum{};
    double lag = 0.0, ebon = 0.0;
    int n = 0;
    std::array<std::vector<double>, 2> jit;
    for (const Cell& c : cells) {
      std::array<const Metrics*, kHorizonsS.size()> x{};
      for (size_t h = 0; h < x.size(); ++h) x[h] = at(ix, c, m, h);
      if (std::find(x.begin(), x.end(), nullptr) != x.end()) continue;
      for (size_t h = 0; h < x.size(); ++h) sum[h] += x[h]->mpjpe_mm;
      lag += x[0]->lag_ms;
      ebon += x[0]->e_bon_mm2;
      jit[0].push_back(x[0]->jitter_mm / x[0]->truth_jitter_mm);
      jit[1].push_back(x[2]->jitter_mm / x[2]->truth_jitter_mm);
      ++n;
    }
    if (n == 0) continue;
    const double k = 1.0 / n;
    s += fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", m, num(sum[0] * k, 2), num(lag * k, 1),
                     num(ebon * k, 1), best[m][0], num(median(jit[0]), 1), num(sum[1] * k, 2), num(sum[2] * k, 2), best[m][1],
                     num(median(jit[1]), 1));
  }
  return s + "\n";
}

// The DGN paper's claim: joints that are missing or heavily corrupted, recovered from
// their neighbours. Mean over the test noise cells of each family of the MPJPE on those
// joints only (H = 0).
std::string occluded_table(const Report& r) {
  std::vector<std::string> families;
  std::map<std::pair<std::string, std::string>, std::pair<double, int>> sum;  // (family, method) -> (sum, cells)
  for (const auto& x : r.results) {
    if (x.cell.block != "noise" || x.occluded.joint_samples == 0 || !std::isfinite(x.occluded.mpjpe_mm)) continue;
    if (std::find(families.begin(), families.end(), x.cell.family) == families.end()) families.push_back(x.cell.family);
    for (const std::string& f : {x.cell.family, std::string("all")}) {
      auto& [s, n] = sum[{f, x.method}];
      s += x.occluded.mpjpe_mm;
      ++n;
    }
  }
  if (families.empty()) return "";
  families.push_back("all");
  std::string s = fmt::format(
      "## Occluded joints (the DGN paper's claim)\n\nMPJPE (mm, H = 0) on the joints each input row lost or displaced by "
      "more than {:g} mm, mean over the test noise cells of each family that has such joints (cells).\n\n",
      kOccludedMm);
  s += header_row({"noise"}, r.methods);
  for (const auto& f : families) {
    s += "| " + f + " |";
    for (const auto& m : r.methods) {
      const auto it = sum.find({f, m});
      s += " " + (it == sum.end() ? std::string("–") : num(it->second.first / it->second.second, 2) + " (" +
                                                           std::to_string(it->second.second) + ")") + " |";
    }
    s += "\n";
  }
  return s + "\n";
}

}  // namespace

std::string report_markdown(const Report& r, const Options& o) {
  const Index ix = index_of(r);
  std::string s = "# HandSteady benchmark\n\n";
  if (!r.command.empty()) {
    s += fmt::format("Made by `{}`", r.command);
    if (!r.revision.empty()) s += fmt::format(" at revision `{}`", r.revision);
    s += ".\n\n";
  }
  const std::string took = r.total_seconds > 0 ? fmt::format("{:.0f} s in all ({:.0f} s the grid)", r.total_seconds, r.seconds)
                                                : fmt::format("{:.0f} s", r.seconds);
  s += fmt::format("Grid: {} cells × {} methods, seed {}, {}; {} on {} threads. Units: mm, ms; jitter = mean "
                   "second difference per input row (mm), shown as a ratio to the truth's where marked. Every method "
                   "runs causally; the answer at t + H is scored against the truth at t + H.\n\n",
                   r.results.size() / std::max<size_t>(1, r.methods.size()), r.methods.size(), o.seed,
                   o.quick ? "**quick subset**" : "full grid", took, o.threads);
  if (o.tuning_split)
    s += "**Scored on the tuning split** (for choosing constants; One Euro is tuned on the same sets).\n\n";
  for (const auto& n : r.notes) s += "- note: " + n + "\n";
  if (!r.notes.empty()) s += "\n";

  s += "## Data\n\n| set | split | rows | grid rate Hz | truth | source |\n|---|---|---:|---:|---|---|\n";
  for (const auto& d : r.sets)
    s += fmt::format("| {} | {} | {} | {} | {} | {} |\n", d.name, d.split, d.rows, d.rate_hz > 0 ? num(d.rate_hz, 0) : "as recorded",
                     d.truth ? "yes" : "no (scored against itself)", d.source);

  s += "\n## Summary\n\n";
  s += summary(r, ix);

  s += "## Criteria (Multi-STGAE v2 issue)\n\n";
  s += criteria(r, ix);
  s += occluded_table(r);

  s += "## One Euro tuned per noise cell (tuning split, minimum MPJPE at H = 0)\n\n";
  s += "| noise | min cutoff Hz | beta s/m | tuning MPJPE |\n|---|---:|---:|---:|\n";
  for (const auto& [key, p] : r.tuned) {
    double best = kNaN;
    for (const auto& t : r.tuning)
      if (t.cell == key && t.params.min_cutoff_hz == p.min_cutoff_hz && t.params.beta == p.beta) best = t.mpjpe_mm;
    s += fmt::format("| {} | {:g} | {:g} | {} |\n", key, p.min_cutoff_hz, p.beta, num(best, 2));
  }
  s += "\n";

  const auto noise = cells_of(r, "noise");
  std::vector<std::string> sets;
  for (const Cell& c : noise)
    if (std::find(sets.begin(), sets.end(), c.dataset) == sets.end()) sets.push_back(c.dataset);
  const auto noise_name = [](const Cell& c) { return std::vector<std::string>{c.family, c.strength}; };
  for (const auto& set : sets) {
    std::vector<Cell> cs;
    for (const Cell& c : noise)
      if (c.dataset == set) cs.push_back(c);
    s += fmt::format("## {}\n\n", set);
    s += "Denoising (H = 0): MPJPE (lag ms)\n\n";
    s += table(r, ix, cs, {"noise", "strength"}, noise_name, 0,
               [](const Metrics& m) { return num(m.mpjpe_mm, 2) + " (" + num(m.lag_ms, 0) + ")"; });
    s += "Denoising (H = 0): jitter ÷ truth's · E_bon mm²\n\n";
    s += table(r, ix, cs, {"noise", "strength"}, noise_name, 0, [](const Metrics& m) {
      return num(m.jitter_mm / m.truth_jitter_mm, 2) + " · " + num(m.e_bon_mm2, 1);
    });
    for (size_t h = 1; h < kHorizonsS.size(); ++h) {
      s += fmt::format("Prediction at {:.0f} ms: MPJPE (jitter ÷ truth's)\n\n", kHorizonsS[h] * 1e3);
      s += table(r, ix, cs, {"noise", "strength"}, noise_name, h, [](const Metrics& m) {
        return num(m.mpjpe_mm, 2) + " (" + num(m.jitter_mm / m.truth_jitter_mm, 2) + ")";
      });
    }
  }

  if (const auto cs = cells_of(r, "rate"); !cs.empty()) {
    s += "## Input rates (irregular times, ±20 % of a period)\n\nMPJPE at H = 0 (lag ms) · MPJPE at 50 ms\n\n";
    s += rate_table(r, ix, cs, "rate Hz", 2, 0);
  }
  if (const auto cs = cells_of(r, "native"); !cs.empty()) {
    s += "## At the recordings' own times (no resampling)\n\nEach set with truth as recorded: its own rows, rate "
         "changes and re-fits. Clean, raw's answer is the truth (0 mm), so a method's error there is all it adds. MPJPE "
         "at H = 0 (lag ms) · MPJPE at 50 ms\n\n";
    s += rate_table(r, ix, cs, "median rate Hz", 3, 1);
  }
  if (const auto cs = cells_of(r, "shape"); !cs.empty()) {
    s += "## Hand shapes (tracker preset)\n\nMPJPE at H = 0 · E_bon mm²\n\n";
    s += table(r, ix, cs, {"set", "shape"}, [](const Cell& c) { return std::vector<std::string>{c.dataset, c.shape}; }, 0,
               [](const Metrics& m) { return num(m.mpjpe_mm, 2) + " · " + num(m.e_bon_mm2, 1); });
  }
  if (const auto cs = cells_of(r, "recorded"); !cs.empty()) {
    s += "## Recordings without truth (scored against the raw recording)\n\n";
    s += "H = 0: jitter mm (raw's) · lag behind raw ms · the least jitter One Euro and Kalman reach at that lag "
         "(their sweeps below, interpolated); H = 20 and 50 ms: distance to the observed future mm (jitter)\n\n";
    for (const Cell& c : cs) {
      s += fmt::format("**{}**\n\n| method | jitter | raw jitter | lag ms | One Euro at this lag | Kalman at this lag | 20 ms "
                       "| 50 ms |\n|---|---:|---:|---:|---:|---:|---:|---:|\n",
                       c.dataset);
      for (const auto& m : r.methods) {
        const Metrics* a = at(ix, c, m, 0);
        const Metrics* b = at(ix, c, m, 1);
        const Metrics* d = at(ix, c, m, 2);
        if (!a || !b || !d) continue;
        s += fmt::format("| {} | {} | {} | {} | {} | {} | {} ({}) | {} ({}) |\n", m, num(a->jitter_mm, 3),
                         num(a->truth_jitter_mm, 3), num(a->lag_ms, 1), num(baseline_jitter_at(r, c, "oneeuro", a->lag_ms), 3),
                         num(baseline_jitter_at(r, c, "kalman", a->lag_ms), 3), num(b->mpjpe_mm, 2), num(b->jitter_mm, 3),
                         num(d->mpjpe_mm, 2), num(d->jitter_mm, 3));
      }
      s += "\n";
      std::string sweep;
      for (const LagPoint& p : r.recorded_curves)
        if (p.cell == c.key()) sweep += fmt::format("| {} | {} | {} | {} |\n", p.method, p.params, num(p.jitter_mm, 3), num(p.lag_ms, 1));
      if (!sweep.empty())
        s += "Sweeps (jitter_lag_" + c.dataset + ".png):\n\n| method | parameters | jitter | lag ms |\n|---|---|---:|---:|\n" +
             sweep + "\n";
    }
  }
  if (!r.still.empty()) {
    s += "## Start and stillness (a still pose, lost for 0.5 s, back)\n\nlargest joint error mm: first 0.3 s · after "
         "the return · drift from 1 s to 2 s · with 0.5 mm jitter, the mean answer from 1 s to 2 s (its largest "
         "joint offset)\n\n";
    s += header_row({"set", "shape"}, r.methods);
    std::vector<std::pair<std::string, std::string>> keys;
    for (const auto& x : r.still)
      if (std::find(keys.begin(), keys.end(), std::pair{x.dataset, x.shape}) == keys.end()) keys.emplace_back(x.dataset, x.shape);
    for (const auto& [set, shape] : keys) {
      s += fmt::format("| {} | {} |", set, shape);
      for (const auto& m : r.methods) {
        std::string cell = "–";
        for (const auto& x : r.still)
          if (x.dataset == set && x.shape == shape && x.method == m)
            cell = num(x.start_mm, 2) + " · " + num(x.resume_mm, 2) + " · " + num(x.drift_mm, 2) + " · " +
                   num(x.noisy_offset_mm, 2);
        s += " " + cell + " |";
      }
      s += "\n";
    }
    s += "\n";
  }
  if (!r.curve.empty()) {
    s += fmt::format("## One Euro's jitter–lag curve ({})\n\nEvery swept parameter pair (curve.csv; plotted in "
                     "oneeuro_curve.png when the benchmark is built with the renderer).\n\n"
                     "| min cutoff Hz | beta s/m | MPJPE | jitter | lag ms |\n|---:|---:|---:|---:|---:|\n",
                     r.curve_cell);
    for (const auto& p : r.curve)
      s += fmt::format("| {:g} | {:g} | {} | {} | {} |\n", p.params.min_cutoff_hz, p.params.beta, num(p.mpjpe_mm, 2),
                       num(p.jitter_mm, 3), num(p.lag_ms, 1));
  }
  return s;
}

std::string report_json(const Report& r, const Options& o) {
  using nlohmann::json;
  const auto metrics = [](const Metrics& m) {
    const auto v = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };
    return json{{"mpjpe_mm", v(m.mpjpe_mm)},   {"e_bon_mm2", v(m.e_bon_mm2)}, {"jitter_mm", v(m.jitter_mm)},
                {"truth_jitter_mm", v(m.truth_jitter_mm)}, {"lag_ms", v(m.lag_ms)}, {"frames", m.frames}};
  };
  json j;
  j["command"] = r.command;
  j["revision"] = r.revision;
  j["quick"] = o.quick;
  j["tuning_split"] = o.tuning_split;
  j["seed"] = o.seed;
  j["seconds"] = r.seconds;
  j["total_seconds"] = r.total_seconds;
  j["methods"] = r.methods;
  j["models"] = r.models;
  j["notes"] = r.notes;
  j["curve_cell"] = r.curve_cell;
  j["curve_label"] = r.curve_label;
  for (const auto& d : r.sets)
    j["sets"].push_back({{"name", d.name}, {"split", d.split}, {"rows", d.rows}, {"rate_hz", d.rate_hz}, {"truth", d.truth},
                         {"source", d.source}});
  for (const auto& [k, p] : r.tuned) j["oneeuro_tuned"][k] = {{"min_cutoff_hz", p.min_cutoff_hz}, {"beta", p.beta}};
  for (const auto& x : r.results) {
    json e{{"block", x.cell.block},   {"set", x.cell.dataset}, {"family", x.cell.family}, {"strength", x.cell.strength},
           {"shape", x.cell.shape},   {"rate_hz", x.cell.rate_hz}, {"level_mm", x.cell.level_mm}, {"method", x.method},
           {"cell", x.cell.key()}};
    for (size_t h = 0; h < kHorizonsS.size(); ++h) e[fmt::format("h{:.0f}ms", kHorizonsS[h] * 1e3)] = metrics(x.at[h]);
    if (x.occluded.joint_samples > 0) {
      e["occluded_h0"] = metrics(x.occluded);
      e["occluded_h0"]["joint_samples"] = x.occluded.joint_samples;
    }
    j["results"].push_back(e);
  }
  for (const auto& x : r.still)
    j["still"].push_back({{"set", x.dataset}, {"shape", x.shape}, {"method", x.method}, {"start_mm", x.start_mm},
                          {"resume_mm", x.resume_mm}, {"drift_mm", x.drift_mm}, {"noisy_offset_mm", x.noisy_offset_mm}});
  for (const auto& p : r.recorded_curves)
    j["recorded_curves"].push_back({{"cell", p.cell}, {"method", p.method}, {"params", p.params}, {"jitter_mm", p.jitter_mm},
                                    {"lag_ms", p.lag_ms}});
  for (const auto& p : r.curve)
    j["oneeuro_curve"].push_back({{"min_cutoff_hz", p.params.min_cutoff_hz}, {"beta", p.params.beta},
                                  {"mpjpe_mm", p.mpjpe_mm}, {"jitter_mm", p.jitter_mm}, {"lag_ms", p.lag_ms}});
  return j.dump(1) + "\n";
}

std::string curve_csv(const Report& r) {
  std::string s = "method,min_cutoff_hz,beta,mpjpe_mm,jitter_mm,lag_ms\n";
  for (const auto& p : r.curve)
    s += fmt::format("oneeuro-sweep,{:g},{:g},{:.4f},{:.5f},{:.3f}\n", p.params.min_cutoff_hz, p.params.beta, p.mpjpe_mm,
                     p.jitter_mm, p.lag_ms);
  // Every method on the same cell, as points.
  for (const auto& x : r.results)
    if (x.cell.key() == r.curve_cell)
      s += fmt::format("{},,,{:.4f},{:.5f},{:.3f}\n", x.method, x.at[0].mpjpe_mm, x.at[0].jitter_mm, x.at[0].lag_ms);
  return s;
}

}  // namespace hs::bench
