#!/usr/bin/env python3
"""Measures tracker-noise statistics of the HoloLens 2 (MRTK) recordings.

Reads ../shared/data/hololens2/*.csv (never copies them) and prints the numbers that
docs/CORRUPTION.md quotes and the `tracker` corruption preset is built from.
Pure python3 (no numpy). Usage: tools/measure_hl2_noise.py [DATA_DIR]

Method (per hand column block, both recordings pooled):
  * hand tracked in a row  <=> at least one of its 26 cells is not "0";
  * whole-hand dropouts    = maximal runs of untracked rows that lie between tracked
    rows (leading/trailing untracked stretches are excluded: the hand was simply not
    in view); duration = time of next tracked row - time of last tracked row - one
    median frame period; start rate = dropouts per second of tracked time;
  * dropped joints         = "0" cells in a row where the hand is otherwise tracked;
  * jitter                 = residual r_t = x_t - (x_{t-1} + x_{t+1}) / 2 per coordinate
    over triples of consecutive tracked rows. For white noise of SD s, var(r) =
    1.5 s^2, so s = 1.4826 * MAD(r) / sqrt(1.5). Motion inflates r, the median (MAD)
    suppresses it: this is an upper bound on the white-noise SD for slow motion.
  * still-hand jitter      = the same estimate restricted to triples in which the wrist
    moved less than 4 mm between t-1 and t+1 (motion contributes little there);
  * whole-hand jitter      = on the same still triples, the mean over the row's joints
    of r (per coordinate) against each joint's r minus that mean: the common-mode and
    the joints' own parts. SD as the RMS of the smallest 98 % over sqrt(1.5) (the 1 mm
    rounding makes r take few values, so its MAD is a multiple of 0.5 mm; the mean over
    26 joints averages the rounding out);
  * second difference      = |x_{t+1} - 2 x_t + x_{t-1}| (3-D norm), median (mm/frame^2);
  * jumps                  = joint residual norms |r| above 6 robust SDs (of the
    3-D residual) AND more than 3x the median residual of the other joints of that row
    (so a fast whole-hand motion is not counted). A one-sample displacement d gives
    |r| = |d|, so the per-coordinate jump SD is rms(|r|) / sqrt(3). Reported as a
    probability per joint per row; fast finger motion also passes the test, so both
    numbers are upper bounds.
"""
import csv
import glob
import math
import os
import statistics
import sys
from datetime import datetime

JOINTS = 26
WRIST = 25  # MRTK column order within a hand block ends with ThumbTip, Wrist


def parse_cell(cell):
    cell = cell.strip()
    if cell in ("", "0"):
        return None
    x, y, z = cell.strip("()").split("/")
    return (float(x), float(y), float(z))


def read_file(path):
    """Returns (times, hands) with hands[h][row] = list of 26 cells (tuple or None)."""
    times = []
    hands = [[], []]
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        first = 3
        for row in reader:
            if len(row) < first + 2 * JOINTS:
                continue
            times.append(datetime.strptime(row[1], "%Y-%m-%d %H:%M:%S.%f").timestamp())
            for h in range(2):
                cells = row[first + h * JOINTS:first + (h + 1) * JOINTS]
                hands[h].append([parse_cell(c) for c in cells])
    return header, times, hands


def mad_sd(values):
    med = statistics.median(values)
    return 1.4826 * statistics.median([abs(v - med) for v in values])


def trimmed_sd(values, keep=0.98):
    """RMS of the smallest `keep` share of |values| (drops jumps and fast flicks)."""
    v = sorted(x * x for x in values)[: max(1, int(len(values) * keep))]
    return math.sqrt(sum(v) / len(v))


def main():
    data_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data", "hololens2")
    files = sorted(glob.glob(os.path.join(data_dir, "*.csv")))
    if not files:
        sys.exit(f"no CSV files in {data_dir}")

    periods = []
    rows_total = rows_tracked = 0
    tracked_time = 0.0
    dropout_frames = []
    dropout_secs = []
    cells_tracked_rows = cells_dropped = 0
    residuals = []          # per coordinate, metres
    resid_norms = []        # per joint, metres (3-D)
    second_diff = []        # per joint, metres
    triples = []            # (row residual norms list) for jump detection
    still_residuals = []    # per coordinate, wrist nearly still
    still_common = []       # per coordinate: the mean of a still row's joint residuals
    still_local = []        # per joint and coordinate: its residual minus that mean

    for path in files:
        _, times, hands = read_file(path)
        for i in range(1, len(times)):
            periods.append(times[i] - times[i - 1])
        for h in range(2):
            rows = hands[h]
            tracked = [any(c is not None for c in r) for r in rows]
            idx = [i for i, tr in enumerate(tracked) if tr]
            if not idx:
                continue
            rows_total += idx[-1] - idx[0] + 1
            rows_tracked += len(idx)
            for a, b in zip(idx, idx[1:]):
                if b == a + 1:
                    tracked_time += times[b] - times[a]
                else:
                    dropout_frames.append(b - a - 1)
                    dropout_secs.append(times[b] - times[a])
            for i in idx:
                cells_tracked_rows += JOINTS
                cells_dropped += sum(1 for c in rows[i] if c is None)
            for i in range(1, len(rows) - 1):
                if not (tracked[i - 1] and tracked[i] and tracked[i + 1]):
                    continue
                norms = []
                row_r = []
                w = [rows[i + d][WRIST] for d in (-1, 0, 1)]
                still = None not in w and math.dist(w[0], w[2]) < 0.004
                for j in range(JOINTS):
                    a, b, c = rows[i - 1][j], rows[i][j], rows[i + 1][j]
                    if a is None or b is None or c is None:
                        continue
                    r = [b[k] - 0.5 * (a[k] + c[k]) for k in range(3)]
                    residuals.extend(r)
                    if still:
                        still_residuals.extend(r)
                        row_r.append(r)
                    n = math.sqrt(sum(v * v for v in r))
                    norms.append(n)
                    second_diff.append(2.0 * n)  # |x+ - 2x + x-| = 2|r|
                if len(row_r) == JOINTS:
                    mean = [sum(r[k] for r in row_r) / JOINTS for k in range(3)]
                    still_common.extend(mean)
                    still_local.extend(r[k] - mean[k] for r in row_r for k in range(3))
                resid_norms.extend(norms)
                triples.append(norms)

    period = statistics.median(periods)
    # Dropout durations: gap minus one frame period (the gap between the last and the
    # next tracked row spans the missing rows plus one period).
    drop_dur = [max(s - period, 0.0) for s in dropout_secs]
    s = mad_sd(residuals) / math.sqrt(1.5)
    thresh = 6.0 * mad_sd(resid_norms) + statistics.median(resid_norms)
    jumps = []
    for norms in triples:
        if len(norms) < 3:
            continue
        med = statistics.median(norms)
        jumps.extend(n for n in norms if n > thresh and n > 3.0 * med)
    print(f"files: {len(files)}")
    print(f"median frame period: {period * 1e3:.1f} ms ({1.0 / period:.1f} Hz); "
          f"period p10/p90: {sorted(periods)[len(periods) // 10] * 1e3:.1f}/"
          f"{sorted(periods)[9 * len(periods) // 10] * 1e3:.1f} ms")
    print(f"hand rows (first..last tracked): {rows_total}, tracked: {rows_tracked}, "
          f"untracked fraction: {1 - rows_tracked / rows_total:.4f}")
    print(f"whole-hand dropouts: {len(dropout_frames)}, per tracked second: "
          f"{len(dropout_frames) / tracked_time:.4f} /s (tracked time {tracked_time:.1f} s)")
    if drop_dur:
        print(f"dropout duration: mean {statistics.mean(drop_dur) * 1e3:.0f} ms, median "
              f"{statistics.median(drop_dur) * 1e3:.0f} ms, frames mean {statistics.mean(dropout_frames):.1f} "
              f"median {statistics.median(dropout_frames)}")
    print(f"dropped joints in tracked rows: {cells_dropped}/{cells_tracked_rows} = "
          f"{cells_dropped / cells_tracked_rows:.5f}")
    print(f"residual coords: {len(residuals)}; robust white-noise SD per coordinate: {s * 1e3:.2f} mm")
    s_still = mad_sd(still_residuals) / math.sqrt(1.5)
    print(f"still-hand residual coords: {len(still_residuals)}; white-noise SD per coordinate: "
          f"{s_still * 1e3:.2f} mm (1 mm rounding alone gives {1 / math.sqrt(12):.2f} mm)")
    if still_common:
        print(f"still rows with all joints: {len(still_common) // 3}; white-noise SD per coordinate (trimmed RMS): "
              f"whole-hand {trimmed_sd(still_common) / math.sqrt(1.5) * 1e3:.2f} mm, "
              f"joints' own {trimmed_sd(still_local) / math.sqrt(1.5) * 1e3:.2f} mm")
    print(f"median second difference |x+ - 2x + x-|: {statistics.median(second_diff) * 1e3:.2f} mm/frame^2")
    print(f"jump threshold |r| > {thresh * 1e3:.1f} mm: {len(jumps)} of {len(resid_norms)} joint samples = "
          f"{len(jumps) / len(resid_norms):.5f} per joint per row")
    if jumps:
        # A displacement d of one sample gives |r| = |d|; per-coordinate SD = |d| / sqrt(3).
        rms = math.sqrt(statistics.mean(j * j for j in jumps))
        print(f"jump residual norm: median {statistics.median(jumps) * 1e3:.1f} mm, rms {rms * 1e3:.1f} mm "
              f"-> per-coordinate SD ~ {rms / math.sqrt(3) * 1e3:.1f} mm")


if __name__ == "__main__":
    main()
