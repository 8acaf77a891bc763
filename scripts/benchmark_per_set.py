#!/usr/bin/env python3
# Mean MPJPE (mm, H = 0) per test set and method over a benchmark run's noise cells
# (benchmark.json "results", block "noise"): the per-set figures README quotes.
# Usage: scripts/benchmark_per_set.py out/benchmark/benchmark.json
import collections, json, sys
if len(sys.argv) != 2:
    sys.exit('usage: benchmark_per_set.py BENCHMARK.json')
j = json.load(open(sys.argv[1]))
acc = collections.defaultdict(list)
for r in j['results']:
    if r['block'] == 'noise':
        acc[(r['set'], r['method'])].append(r['h0ms']['mpjpe_mm'])
methods = j['methods']
print('| set | ' + ' | '.join(methods) + ' |')
print('|---|' + '---:|' * len(methods))
for s in sorted({s for s, _ in acc}):
    print(f'| {s} | ' + ' | '.join(f'{sum(v) / len(v):.2f}' if (v := acc[(s, m)]) else '–' for m in methods) + ' |')
