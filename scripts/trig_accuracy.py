#!/usr/bin/env python3
"""Accuracy of src/reference/trig.rs's sin_cos against mpmath (50 digits), replaying its f64
arithmetic operation by operation (Python floats are IEEE doubles, no FMA, as the Rust build).
Usage: scripts/trig_accuracy.py [N]  (N grid points on [0, π], default 200000)."""
import math, struct, sys
import mpmath as mp

mp.mp.dps = 50
PIO2_LO = float(mp.pi / 2 - mp.mpf(math.pi / 2))  # π/2 − fl(π/2)
assert PIO2_LO == 6.123233995736766e-17
ROUND = 6755399441055744.0
S = [-1 / 6, 1 / 120, -1 / 5040, 1 / 362880, -1 / 39916800, 1 / 6227020800, -1 / 1307674368000, 1 / 355687428096000]
C = [1 / 24, -1 / 720, 1 / 40320, -1 / 3628800, 1 / 479001600, -1 / 87178291200, 1 / 20922789888000, -1 / 6402373705728000]
FRAC_2_PI = 2 / math.pi

def bits(x):
    return struct.unpack('<Q', struct.pack('<d', x))[0]

def fast(x):
    t = x * FRAC_2_PI + ROUND
    q = bits(t) & 3
    k = t - ROUND
    r = (x - k * (math.pi / 2)) - k * PIO2_LO
    z = r * r
    ps, pc = S[7], C[7]
    for j in range(6, -1, -1):
        ps = ps * z + S[j]
        pc = pc * z + C[j]
    s = r + r * (z * ps)
    c = (1.0 - 0.5 * z) + (z * z) * pc
    a, b = (c, s) if q & 1 else (s, c)
    return (-a if q == 2 else a), (-b if q != 0 else b)

def ulp(v):
    v = abs(v)
    return math.ulp(v) if v > 0 else 5e-324

n = int(sys.argv[1]) if len(sys.argv) > 1 else 200000
worst = [0.0, 0.0, 0.0, 0.0]  # ours vs truth (sin, cos), std vs truth (sin, cos)
for i in range(n + 1):
    x = math.pi * i / n
    s, c = fast(x)
    ts, tc = mp.sin(mp.mpf(x)), mp.cos(mp.mpf(x))
    for j, (v, t) in enumerate([(s, ts), (c, tc), (math.sin(x), ts), (math.cos(x), tc)]):
        e = float(abs(mp.mpf(v) - t)) / ulp(float(t))
        worst[j] = max(worst[j], e)
print(f"{n + 1} points on [0, pi]: worst error in ulps of the true value: "
      f"ours sin {worst[0]:.3f} cos {worst[1]:.3f}; std (glibc) sin {worst[2]:.3f} cos {worst[3]:.3f}")
