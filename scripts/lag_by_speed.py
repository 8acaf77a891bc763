#!/usr/bin/env python3
# Where a filter's error lies against the hand's motion: per joint and row, its error
# against the truth split along the joint's true velocity (negative: behind the hand) and
# across it, binned by the joint's true speed (central difference of the truth), pooled over
# files. A lag shows as an along-error that grows with speed; noise as an across-error.
# Inputs are track CSVs with the same rows (docs/TRACK_FORMAT.md), e.g. `handsteady
# resample` -> `corrupt` -> `filter` outputs of one take. docs/STGAE.md "Fast free-air motion".
# Usage: scripts/lag_by_speed.py TRUTH.csv LABEL=OUT.csv [LABEL=OUT.csv ...] [-- TRUTH2.csv ...]
#   each group: a truth, then its outputs; the labels must be the same in every group.
import math, sys

BINS = [0.0, 0.2, 0.5, 1.0, float('inf')]  # joint speed, m/s


def load(path):
    rows = {}
    with open(path) as f:
        names = None
        for n, line in enumerate(f, 1):
            if line.startswith('#'):
                continue
            fields = line.rstrip('\n').split(',')
            if names is None:
                if fields[:2] != ['t', 'hand']:
                    sys.exit(f'{path}:{n}: expected the header t,hand,...')
                names = fields
                continue
            if len(fields) != len(names):
                sys.exit(f'{path}:{n}: {len(fields)} fields, the header has {len(names)}')
            try:
                v = [float(x) if x else math.nan for x in fields[2:]]
                rows[(fields[1], round(float(fields[0]), 6))] = [v[i:i + 3] for i in range(0, len(v), 3)]
            except ValueError as e:
                sys.exit(f'{path}:{n}: {e}')
    return rows


def groups(args):
    cur = []
    for a in args + ['--']:
        if a == '--':
            if cur:
                yield cur[0], [x.split('=', 1) for x in cur[1:]]
            cur = []
        else:
            cur.append(a)


def main():
    args = sys.argv[1:]
    if len(args) < 2:
        sys.exit('usage: lag_by_speed.py TRUTH.csv LABEL=OUT.csv [LABEL=OUT.csv ...] [-- TRUTH2.csv ...]')
    stats = {}  # (label, bin) -> [n, |e|, along, across, lag ms]
    labels = None
    for truth_path, outs in groups(args):
        if any(len(o) != 2 for o in outs):
            sys.exit('outputs are LABEL=FILE.csv')
        if labels is None:
            labels = [l for l, _ in outs]
        elif labels != [l for l, _ in outs]:
            sys.exit('every group must name the same labels in the same order')
        truth = load(truth_path)
        data = [(l, load(p)) for l, p in outs]
        by_hand = {}
        for hand, t in truth:
            by_hand.setdefault(hand, []).append(t)
        for hand, times in by_hand.items():
            times.sort()
            for k in range(1, len(times) - 1):
                a, b, c = (truth[(hand, times[i])] for i in (k - 1, k, k + 1))
                dt = times[k + 1] - times[k - 1]
                for j in range(len(b)):
                    v = [(c[j][i] - a[j][i]) / dt for i in range(3)]
                    sp = math.sqrt(sum(x * x for x in v))
                    if not math.isfinite(sp) or sp < 1e-6 or not all(map(math.isfinite, b[j])):
                        continue
                    u = [x / sp for x in v]
                    bin_ = next(i for i in range(len(BINS) - 1) if sp < BINS[i + 1])
                    for label, rows in data:
                        p = rows.get((hand, times[k]))
                        if p is None or j >= len(p) or not all(map(math.isfinite, p[j])):
                            continue
                        e = [p[j][i] - b[j][i] for i in range(3)]
                        along = sum(e[i] * u[i] for i in range(3))
                        across = math.sqrt(max(sum(x * x for x in e) - along * along, 0.0))
                        s = stats.setdefault((label, bin_), [0, 0.0, 0.0, 0.0, 0.0])
                        s[0] += 1
                        s[1] += math.sqrt(sum(x * x for x in e)) * 1e3
                        s[2] += along * 1e3
                        s[3] += across * 1e3
                        s[4] += -along / sp * 1e3
    print('| joint speed m/s | method | joint rows | error mm | along the velocity mm | across mm | lag ms (−along ÷ speed) |')
    print('|---|---|---:|---:|---:|---:|---:|')
    for i in range(len(BINS) - 1):
        hi = '' if math.isinf(BINS[i + 1]) else f'{BINS[i + 1]:g}'
        for label in labels or []:
            s = stats.get((label, i))
            if not s:
                continue
            n = s[0]
            print(f'| {BINS[i]:g}–{hi} | {label} | {n} | {s[1] / n:.3f} | {s[2] / n:.3f} | {s[3] / n:.3f} | {s[4] / n:.2f} |')
    for label in labels or []:  # every moving joint row (over 1 mm/s)
        t = [sum(stats[(label, i)][k] for i in range(len(BINS) - 1) if (label, i) in stats) for k in range(5)]
        if t[0]:
            print(f'| all | {label} | {t[0]} | {t[1] / t[0]:.3f} | {t[2] / t[0]:.3f} | {t[3] / t[0]:.3f} | {t[4] / t[0]:.2f} |')


if __name__ == '__main__':
    main()
