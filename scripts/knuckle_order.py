#!/usr/bin/env python3
"""Whether a tracker ever puts the four finger knuckles out of their order across the palm
(index, middle, ring, little), as a tracker that swaps two fingers whole would. For every
row of every track CSV under DIR with all four metacarpals and knuckles (*_PROXIMAL), the
knuckles are projected on the palm's across axis (index metacarpal + knuckle to little
metacarpal + knuckle); a row is out of order where a neighbour pair comes in reverse.

  scripts/knuckle_order.py ../shared/data/leap

docs/BENCHMARK.md "Input the grid does not hold" (finger swaps).
"""
import glob
import math
import os
import sys

FINGERS = ("index", "middle", "ring", "little")


def main():
    if len(sys.argv) != 2 or not os.path.isdir(sys.argv[1]):
        sys.exit(__doc__)
    rows = out = 0
    for path in sorted(glob.glob(os.path.join(sys.argv[1], "**", "*.csv"), recursive=True)):
        header = None
        with open(path) as f:
            for n, line in enumerate(f, 1):
                if line.startswith("#"):
                    continue
                v = line.rstrip("\n").split(",")
                if header is None:
                    header = {h: i for i, h in enumerate(v)}
                    if any(f"{fg}_{j}_x" not in header for fg in FINGERS for j in ("metacarpal", "proximal")):
                        break  # not a track CSV
                    continue

                def point(joint):
                    try:
                        p = [float(v[header[f"{joint}_{c}"]]) for c in "xyz"]
                    except (ValueError, IndexError):
                        return None
                    return p if all(math.isfinite(x) for x in p) else None

                meta = [point(f"{fg}_metacarpal") for fg in FINGERS]
                knuckle = [point(f"{fg}_proximal") for fg in FINGERS]
                if any(p is None for p in meta + knuckle):
                    continue
                axis = [meta[3][c] + knuckle[3][c] - meta[0][c] - knuckle[0][c] for c in range(3)]
                norm = math.sqrt(sum(a * a for a in axis))
                if norm == 0:
                    continue
                s = [sum(k[c] * axis[c] for c in range(3)) / norm for k in knuckle]
                rows += 1
                if any(s[i + 1] < s[i] for i in range(3)):
                    out += 1
                    if out <= 10:
                        print(f"{path}:{n}: knuckles out of order (t {v[0]}, {v[1]} hand)")
    print(f"{rows} rows with all four knuckles, {out} out of order")


if __name__ == "__main__":
    main()
