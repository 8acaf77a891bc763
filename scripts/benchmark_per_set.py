#!/usr/bin/env python3
# Mean MPJPE (mm, H = 0) per test set and method over a benchmark run's noise cells
# (benchmark.json "results", block "noise"): the per-set figures README quotes.
# With --by-rate: per input rate and method, the means over cells of MPJPE at H = 0 and
# 50 ms and of each cell's jitter / the truth's at both (models/MODEL.md's per-rate figures).
# With --cells A.json LABEL_A B.json LABEL_B: method B against method A (two runs of the same
# grid and seed, or one run), cell by cell: means at H = 0, 20 and 50 ms, the median jitter ÷ the
# truth's at H = 0 and 50 ms, the mean lag, the occluded joints' MPJPE per family, per set at H = 0
# and 50 ms, and the cells where B's H = 0 MPJPE is more than 0.5 % lower / higher; at 50 ms
# the same count and every noise cell's change, then each cell of the other blocks (rates,
# hand shapes, recordings at their own times or without truth) at H = 0 and 50 ms.
# Usage: scripts/benchmark_per_set.py [--by-rate] out/benchmark/benchmark.json
#        scripts/benchmark_per_set.py --cells A.json LABEL_A B.json LABEL_B
import collections, json, statistics, sys
args = sys.argv[1:]
if args[:1] == ['--cells']:
    if len(args) != 5:
        sys.exit('usage: benchmark_per_set.py --cells A.json LABEL_A B.json LABEL_B')
    def cells(path, label):  # (noise cells, the other blocks' cells) of one method, by cell
        rows = [r for r in json.load(open(path))['results'] if r['method'] == label]
        noise = {r['cell']: r for r in rows if r['block'] == 'noise'}
        if not noise:
            sys.exit(f'{path}: no noise cells of method {label}')
        return noise, {r['cell']: r for r in rows if r['block'] != 'noise'}
    (a, oa), (b, ob) = cells(args[1], args[2]), cells(args[3], args[4])
    if a.keys() != b.keys():
        sys.exit('the two runs have different noise cells')
    mean = lambda v: sum(v) / len(v)
    for h in ('h0ms', 'h20ms', 'h50ms'):
        print(f'{h}: {mean([a[c][h]["mpjpe_mm"] for c in a]):.4f} -> {mean([b[c][h]["mpjpe_mm"] for c in a]):.4f} mm')
    for h in ('h0ms', 'h50ms'):
        ratio = lambda d, c: d[c][h]['jitter_mm'] / d[c][h]['truth_jitter_mm']
        print(f'{h} median jitter / truth\'s: {statistics.median([ratio(a, c) for c in a]):.2f} -> '
              f'{statistics.median([ratio(b, c) for c in a]):.2f}')
    print(f'h0ms mean lag: {mean([a[c]["h0ms"]["lag_ms"] for c in a]):.2f} -> {mean([b[c]["h0ms"]["lag_ms"] for c in a]):.2f} ms')
    # The occluded joints (benchmark.md "Occluded joints"): per noise family, the mean over the
    # noise cells that have such joints in both runs.
    occ = collections.defaultdict(list)
    for c in a:
        if 'occluded_h0' in a[c] and 'occluded_h0' in b[c]:
            occ[a[c]['family']].append((a[c]['occluded_h0']['mpjpe_mm'], b[c]['occluded_h0']['mpjpe_mm']))
    for f in sorted(occ):
        print(f'h0ms occluded joints, {f} ({len(occ[f])} cells): {mean([x for x, _ in occ[f]]):.3f} -> '
              f'{mean([y for _, y in occ[f]]):.3f} mm')
    for s in sorted({r['set'] for r in a.values()}):
        cs = [c for c in a if a[c]['set'] == s]
        x0, y0 = mean([a[c]['h0ms']['mpjpe_mm'] for c in cs]), mean([b[c]['h0ms']['mpjpe_mm'] for c in cs])
        x5, y5 = mean([a[c]['h50ms']['mpjpe_mm'] for c in cs]), mean([b[c]['h50ms']['mpjpe_mm'] for c in cs])
        print(f'{s}: H = 0 {x0:.3f} -> {y0:.3f} ({100 * (y0 / x0 - 1):+.1f} %), 50 ms {x5:.3f} -> {y5:.3f} ({100 * (y5 / x5 - 1):+.1f} %)')
    ratio = [b[c]['h0ms']['mpjpe_mm'] / a[c]['h0ms']['mpjpe_mm'] for c in a]
    print(f'cells better / worse by more than 0.5 % at H = 0: {sum(r < 0.995 for r in ratio)} / '
          f'{sum(r > 1.005 for r in ratio)} of {len(ratio)}')
    r50 = {c: b[c]['h50ms']['mpjpe_mm'] / a[c]['h50ms']['mpjpe_mm'] for c in a}
    print(f'cells better / worse by more than 0.5 % at 50 ms: {sum(r < 0.995 for r in r50.values())} / '
          f'{sum(r > 1.005 for r in r50.values())} of {len(r50)}')
    for c in sorted(r50, key=r50.get):  # every noise cell's 50 ms change, best first
        print(f'  50 ms {100 * (r50[c] - 1):+.1f} %  {c}')
    # The other blocks (rates, hand shapes, recordings at their own times or without truth),
    # cell by cell at H = 0 and 50 ms.
    for c in sorted(oa.keys() & ob.keys()):
        x0, y0 = oa[c]['h0ms']['mpjpe_mm'], ob[c]['h0ms']['mpjpe_mm']
        x, y = oa[c]['h50ms']['mpjpe_mm'], ob[c]['h50ms']['mpjpe_mm']
        ch0 = f' ({100 * (y0 / x0 - 1):+.1f} %)' if x0 > 0 else ''
        print(f'{c}: H = 0 {x0:.3f} -> {y0:.3f}{ch0}, 50 ms {x:.3f} -> {y:.3f} ({100 * (y / x - 1):+.1f} %)')
    sys.exit(0)
by_rate = args[:1] == ['--by-rate']
if by_rate:
    args = args[1:]
if len(args) != 1:
    sys.exit('usage: benchmark_per_set.py [--by-rate] BENCHMARK.json')
j = json.load(open(args[0]))
methods = j['methods']
acc = collections.defaultdict(list)
for r in j['results']:
    if r['block'] != 'noise':
        continue
    if by_rate:
        h0, h50 = r['h0ms'], r['h50ms']
        acc[(r['rate_hz'], r['method'])].append((h0['mpjpe_mm'], h50['mpjpe_mm'],
                                                h0['jitter_mm'] / h0['truth_jitter_mm'],
                                                h50['jitter_mm'] / h50['truth_jitter_mm']))
    else:
        acc[(r['set'], r['method'])].append(r['h0ms']['mpjpe_mm'])
if by_rate:
    print('| rate Hz | method | cells | H = 0 MPJPE | 50 ms MPJPE | jitter ratio | 50 ms jitter ratio |')
    print('|---:|---|---:|---:|---:|---:|---:|')
    for rate in sorted({k for k, _ in acc}):
        for m in methods:
            if v := acc[(rate, m)]:
                means = [sum(x[i] for x in v) / len(v) for i in range(4)]
                print(f'| {rate:g} | {m} | {len(v)} | ' + ' | '.join(f'{x:.3f}' for x in means) + ' |')
    sys.exit(0)
print('| set | ' + ' | '.join(methods) + ' |')
print('|---|' + '---:|' * len(methods))
for s in sorted({s for s, _ in acc}):
    print(f'| {s} | ' + ' | '.join(f'{sum(v) / len(v):.2f}' if (v := acc[(s, m)]) else '–' for m in methods) + ' |')
