#!/usr/bin/env python3
# A track replayed at irregular times: each hand linearly interpolated at times whose
# intervals are (1 / RATE) * U(1 - JITTER, 1 + JITTER), seeded (random.seed(5)); a joint is
# untracked where its bracketing rows are more than 250 ms apart. For checking the
# streaming adapter at rates and timings the benchmark grid does not have (docs/STGAE.md).
# Usage: scripts/jitter_times.py IN.csv RATE JITTER OUT.csv   (e.g. 75 0.2)
import sys, math, random
if len(sys.argv) != 5:
    sys.exit('usage: jitter_times.py IN.csv RATE JITTER OUT.csv')
src, rate, jit, out = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
random.seed(5)
meta, header, rows = [], None, {}
for line in open(src):
    if line.startswith('#'):
        if not line.startswith('# rate_hz'): meta.append(line)
        continue
    if header is None: header = line; continue
    f = line.rstrip('\n').split(',')
    vals = [float(x) if x not in ('', 'nan') else math.nan for x in f[2:]]
    rows.setdefault(f[1], []).append((float(f[0]), vals))
outrows = []
for h, R in rows.items():
    t = R[0][0]; k = 0
    while True:
        while k + 1 < len(R) and R[k + 1][0] < t: k += 1
        if k + 1 >= len(R): break
        (ta, a), (tb, b) = R[k], R[k + 1]
        if tb - ta > 0.25: vals = [math.nan] * len(a)
        else:
            w = (t - ta) / (tb - ta); vals = [x + w * (y - x) for x, y in zip(a, b)]
        outrows.append((t, h, vals))
        t += (1 / rate) * random.uniform(1 - jit, 1 + jit)
outrows.sort(key=lambda r: r[0])
with open(out, 'w') as o:
    o.writelines(meta); o.write('# rate_hz: %g\n' % rate); o.write(header)
    for t, h, vals in outrows:
        o.write('%.9f,%s,%s\n' % (t, h, ','.join('' if math.isnan(v) else '%.7f' % v for v in vals)))
