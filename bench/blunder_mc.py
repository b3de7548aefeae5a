#!/usr/bin/env python3
"""How often the blunder-by-distances warning (accuracy::distances,
`BLUNDER_M`) names a target of a correct map, and how often it finds a
real blunder: a Monte Carlo of N targets spread over a SPAN m square, each
map position off its survey by independent Gaussian errors per axis (map
and survey together), one target moved by BLUNDER m in a random direction
for the detection rate. The rule is the Rust one, rewritten: each target
tried as the suspect, the common scale (clamped to ±0.5 %) from the pairs
without it, the suspect whose removal leaves the others agreeing best;
named when its median pair misfit is over RATIO × the others' median and
over FLOOR. (One round only: later rounds need a first blunder.)

Usage: bench/blunder_mc.py [FLOOR=0.10] [RATIO=5] [TRIALS=1500]
Pure Python; about a minute.
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


def suspect(m, s):
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


def rate(n, sigma, blunder, rng, count):
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
print("| error per axis | targets | false alarms | 20 cm blunder found |")
print("|---|---|---|---|")
for sigma in (0.005, 0.02, 0.03):
    for n in (5, 6, 8):
        rng = random.Random(3)
        fa = rate(n, sigma, 0.0, rng, trials)
        det = rate(n, sigma, BLUNDER, rng, trials // 2)
        print(f"| {sigma * 1e3:.0f} mm | {n} | {100 * fa:.1f} % | {100 * det:.0f} % |")
