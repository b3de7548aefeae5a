#!/usr/bin/env python3
"""How often the survey-blunder warning (`Warning::LayoutMisfit`,
accuracy::blunder, `BLUNDER_M`) names a target of a correct map, and how
often it finds a real blunder: a Monte Carlo of N targets spread over a
SPAN m square, each map position off its survey by independent Gaussian
errors per axis (map and survey together), one target moved by 20 cm (and
12 cm) in a random direction for the detection rate. The rule is the Rust
one, rewritten: each target left out in turn, a rigid 2D fit on the
others; the suspect is the one whose leaving out lets the others fit best;
named when its distance from where that fit places it is over FLOOR and
over RATIO x the others' rms residual (with four targets, the distance
weighed by its leverage is held against FLOOR). Beside it, the rule it replaced
(distances: each target's median pair misfit against the other pairs'),
for comparison. (One round only: later rounds need a first blunder.)

Usage: bench/blunder_mc.py [FLOOR=0.10] [RATIO=5] [TRIALS=1500]
Pure Python; a few minutes.
"""
import math
import random
import sys

floor = float(sys.argv[1]) if len(sys.argv) > 1 else 0.10
ratio = float(sys.argv[2]) if len(sys.argv) > 2 else 5.0
trials = int(sys.argv[3]) if len(sys.argv) > 3 else 1500
SPAN, BLUNDER = 100.0, 0.2


def med(v):
    v = sorted(v)
    return v[(len(v) - 1) // 2]


def fit2d(m, s):
    """Rigid 2D fit of m onto s (Procrustes about the centroids)."""
    n = len(m)
    mx, my = sum(p[0] for p in m) / n, sum(p[1] for p in m) / n
    sx, sy = sum(p[0] for p in s) / n, sum(p[1] for p in s) / n
    a = b = 0.0
    for (x, y), (u, v) in zip(m, s):
        x, y, u, v = x - mx, y - my, u - sx, v - sy
        a += x * u + y * v
        b += x * v - y * u
    c, sn = math.cos(math.atan2(b, a)), math.sin(math.atan2(b, a))
    return lambda p: (c * (p[0] - mx) - sn * (p[1] - my) + sx,
                      sn * (p[0] - mx) + c * (p[1] - my) + sy)


def left_out(m, s):
    """accuracy::blunder::left_out_misfits, one round."""
    n = len(m)
    best = None
    for k in range(n):
        mo = [m[i] for i in range(n) if i != k]
        so = [s[i] for i in range(n) if i != k]
        t = fit2d(mo, so)
        rms = math.sqrt(sum(math.dist(t(p), q) ** 2 for p, q in zip(mo, so)) / len(mo))
        off = math.dist(t(m[k]), s[k])
        weighed = off
        if n < 5:
            # Three left extrapolate to the fourth: weigh by its leverage.
            cx = sum(p[0] for p in so) / len(so)
            cy = sum(p[1] for p in so) / len(so)
            spread = sum((p[0] - cx) ** 2 + (p[1] - cy) ** 2 for p in so)
            d2 = (s[k][0] - cx) ** 2 + (s[k][1] - cy) ** 2
            weighed = off / math.sqrt(1 + 1 / len(so) + d2 / (2 * spread))
        if best is None or rms < best[0]:
            best = (rms, k, off, weighed)
    rms, k, off, weighed = best
    return k if weighed > floor and off > ratio * rms else None


def by_distances(m, s):
    n = len(m)
    d = lambda a, b: math.hypot(a[0] - b[0], a[1] - b[1])
    P = [[None] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1, n):
            P[i][j] = P[j][i] = (d(m[i], m[j]), d(s[i], s[j]))
    best = None
    for k in range(n):
        rest = [P[i][j] for i in range(n) for j in range(i + 1, n) if k not in (i, j)]
        ratios = [p[0] / p[1] for p in rest if p[1] > 1.0]
        sc = min(max(med(ratios), 0.995), 1.005) if ratios else 1.0
        res = [abs(p[0] - sc * p[1]) for p in rest]
        score = sum(r * r for r in res)
        own = med([abs(P[k][j][0] - sc * P[k][j][1]) for j in range(n) if j != k])
        if best is None or score < best[0]:
            best = (score, k, med(res), own)
    _, k, others, own = best
    return k if own > ratio * others and own > floor else None


def rate(suspect, n, sigma, blunder, rng, count):
    hits = 0
    for _ in range(count):
        s = [(rng.uniform(0, SPAN), rng.uniform(0, SPAN)) for _ in range(n)]
        m = [(x + rng.gauss(0, sigma), y + rng.gauss(0, sigma)) for x, y in s]
        if blunder:
            a = rng.uniform(0, 2 * math.pi)
            m[0] = (m[0][0] + blunder * math.cos(a), m[0][1] + blunder * math.sin(a))
        k = suspect(m, s)
        hits += k is not None and (not blunder or k == 0)
    return hits / count


print(f"floor {floor} m, ratio {ratio}, {trials} trials, targets over {SPAN:.0f} m")
print("| error per axis | targets | false alarms | 20 cm blunder found | 12 cm found "
      "| by distances: false alarms | 20 cm found |")
print("|---|---|---|---|---|---|---|")
for sigma in (0.005, 0.02, 0.03):
    for n in (4, 5, 6, 8):
        row = []
        for rule in (left_out, by_distances):
            rng = random.Random(3)
            row.append(rate(rule, n, sigma, 0.0, rng, trials))
            row.append(rate(rule, n, sigma, BLUNDER, rng, trials // 2))
            if rule is left_out:
                row.append(rate(rule, n, sigma, 0.12, rng, trials // 2))
        print(f"| {sigma * 1e3:.0f} mm | {n} | " + " | ".join(f"{100 * x:.1f} %" for x in row) + " |")
