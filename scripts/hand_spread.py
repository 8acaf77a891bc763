#!/usr/bin/env python3
# How far real hands spread across their second principal axis: per track CSV (docs/
# TRACK_FORMAT.md), the least RMS spread of a row's tracked joints along the second axis
# of their covariance, over rows with at least 20 tracked joints. The layer's gate takes a
# hand under 3 mm for one collapsed onto a point or a line (plugin/src/joint_gate.hpp
# GateLimits::min_spread_m); docs/OPENXR_LAYER.md quotes this script's output.
# Usage: scripts/hand_spread.py TRACK.csv...   (prints rows judged and the least spread, mm)
import math, sys


def eigenvalues(c):  # ascending eigenvalues of a symmetric 3x3 matrix (trigonometric method)
    off = c[0][1] ** 2 + c[0][2] ** 2 + c[1][2] ** 2
    q = (c[0][0] + c[1][1] + c[2][2]) / 3
    if off < 1e-30:
        return sorted([c[0][0], c[1][1], c[2][2]])
    p = math.sqrt(((c[0][0] - q) ** 2 + (c[1][1] - q) ** 2 + (c[2][2] - q) ** 2 + 2 * off) / 6)
    b = [[(c[i][j] - (q if i == j else 0.0)) / p for j in range(3)] for i in range(3)]
    det = (b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
           b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]))
    phi = math.acos(max(-1.0, min(1.0, det / 2))) / 3
    hi, lo = q + 2 * p * math.cos(phi), q + 2 * p * math.cos(phi + 2 * math.pi / 3)
    return sorted([hi, 3 * q - hi - lo, lo])


def least_spread(path):
    rows, least, where = 0, math.inf, None
    with open(path) as f:
        for line in f:
            if not line.strip() or line.startswith('#') or line.startswith('t,'):
                continue
            v = line.rstrip('\n').split(',')
            pts = []
            for j in range(2, len(v) - 2, 3):
                if v[j] and v[j + 1] and v[j + 2]:
                    p = tuple(float(x) for x in v[j:j + 3])
                    if all(math.isfinite(x) for x in p):
                        pts.append(p)
            if len(pts) < 20:
                continue
            rows += 1
            n = len(pts)
            m = [sum(p[k] for p in pts) / n for k in range(3)]
            cov = [[sum((p[i] - m[i]) * (p[j] - m[j]) for p in pts) / n for j in range(3)] for i in range(3)]
            s = math.sqrt(max(eigenvalues(cov)[1], 0.0))
            if s < least:
                least, where = s, f't = {v[0]} s, {v[1]} hand'
    return rows, least, where


if len(sys.argv) < 2:
    sys.exit('usage: hand_spread.py TRACK.csv...')
total, least, where = 0, math.inf, None
for path in sys.argv[1:]:
    rows, s, w = least_spread(path)
    total += rows
    if s < least:
        least, where = s, f'{path}, {w}'
print(f'{total} rows of 20 or more tracked joints; least spread along the second axis: '
      f'{least * 1e3:.1f} mm ({where})' if total else 'no row with 20 or more tracked joints')
