#!/usr/bin/env python3
# Mean MPJPE (mm, H = 0) per test set and method over a benchmark run's noise cells
# (benchmark.json "results", block "noise"): the per-set figures README quotes.
# With --by-rate: per input rate and method, the means over cells of MPJPE at H = 0 and
# 50 ms and of each cell's jitter / the truth's at both (models/MODEL.md's per-rate figures).
# Usage: scripts/benchmark_per_set.py [--by-rate] out/benchmark/benchmark.json
import collections, json, sys
args = sys.argv[1:]
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
