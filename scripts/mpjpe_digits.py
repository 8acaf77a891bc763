#!/usr/bin/env python3
# MPJPE (mm, H = 0) of track CSVs against a clean one, to four decimals: the mean Euclidean
# distance over every joint of every row (time and hand) present and finite in both files,
# as `handsteady compare` reports it to two. For telling apart FPHA table rows that round alike
# (models/MODEL.md). Usage: scripts/mpjpe_digits.py CLEAN.csv OUT.csv [OUT.csv ...]
import csv
import math
import sys


def load(path):
    rows = {}
    with open(path) as f:
        reader = csv.reader(line for line in f if not line.startswith('#'))
        header = next(reader)
        if header[:2] != ['t', 'hand']:
            sys.exit(f'{path}: line 1: expected a header starting "t,hand", got {header[:2]}')
        for n, row in enumerate(reader, start=2):
            if len(row) != len(header):
                sys.exit(f'{path}: row {n}: {len(row)} fields, the header has {len(header)}')
            rows[(round(float(row[0]), 6), row[1])] = [float(v) if v else math.nan for v in row[2:]]
    return rows


if len(sys.argv) < 3:
    sys.exit('usage: mpjpe_digits.py CLEAN.csv OUT.csv [OUT.csv ...]')
truth = load(sys.argv[1])
for path in sys.argv[2:]:
    total, count = 0.0, 0
    for key, values in load(path).items():
        clean = truth.get(key)
        if clean is None:
            continue
        for j in range(0, min(len(values), len(clean)) - 2, 3):
            d = [values[j + i] - clean[j + i] for i in range(3)]
            if all(math.isfinite(x) for x in d):
                total += math.sqrt(sum(x * x for x in d))
                count += 1
    if count == 0:
        sys.exit(f'{path}: no joint in common with {sys.argv[1]}')
    print(f'{path}: MPJPE {1000 * total / count:.4f} mm over {count} joints')
