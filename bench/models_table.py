#!/usr/bin/env python3
"""The per-model table of issue 33: Ls, spheres and checkerboard boards in one
mixed scene, with clutter, seen from 5-30 m: found, error, how often the 95 %
ellipse (horizontal, chi2_2 = 5.991) and ellipsoid (3D, chi2_3 = 7.815) hold
the truth, and wrong objects taken (located more than 5 cm from the truth).

Usage: bench/models_table.py BIN SEEDS [POINTS] [DIST] [DECOYS] [FORMAT] [NOISE]
  e.g. bench/models_table.py target/release/mapgauge 8 4000000 5,30 4 pcd-xyzi
Each seed: `synth --models l,sphere,board --targets 9` (3 of each) with
DECOYS scene-wide decoys (building corners, L boards, cabinets, small Ls,
pallets), the synth's poles, and a plain sign of a board's size standing in
each board's plane 0.4 m beside it; `eval --no-report`; each located point
(eval.targets[].corner_in_map, the map's own frame) against truth.json's,
with result.json's map_covariance. Needs numpy.
"""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

binary, seeds = sys.argv[1], int(sys.argv[2])
points = sys.argv[3] if len(sys.argv) > 3 else "4000000"
dist = sys.argv[4] if len(sys.argv) > 4 else "5,30"
decoys = sys.argv[5] if len(sys.argv) > 5 else "4"
fmt = sys.argv[6] if len(sys.argv) > 6 else "pcd-xyzi"
# The LiDAR's range noise (m, 1 sigma); synth's default when not given.
noise = sys.argv[7] if len(sys.argv) > 7 else None
ext = {"laz": "laz", "las": "las", "ply-f32": "ply"}.get(fmt, "pcd")
rows = {"l": [], "sphere": [], "board": []}
missed = {"l": [], "sphere": [], "board": []}
for seed in range(1, seeds + 1):
    with tempfile.TemporaryDirectory() as d:
        scene, out, cfg = Path(d) / "scene", Path(d) / "out", Path(d) / "signs.toml"
        lidar = f"[lidar]\nrange_noise_m = {noise}\n" if noise else ""
        cfg.write_text("[board]\nsign_gap_m = 0.4\n" + lidar)
        subprocess.run([binary, "synth", "--out", str(scene), "--points", points,
                        "--seed", str(seed), "--models", "l,sphere,board", "--targets", "9",
                        "--target-distance-m", dist, "--decoys", decoys, "--format", fmt,
                        "--config", str(cfg)],
                       check=True, capture_output=True)
        subprocess.run([binary, "eval", "--map", str(scene / f"map.{ext}"),
                        "--survey", str(scene / "survey.csv"), "--out", str(out),
                        "--no-report"], capture_output=True)
        r = json.loads((out / "result.json").read_text())
        t = json.loads((scene / "truth.json").read_text())
        tt = {x["id"]: x for x in t["targets"]}
        for e, rt in zip(r["eval"]["targets"], r["targets"]):
            model = e.get("model") or "l"
            T = tt[e["id"]]
            if e.get("corner_in_map") is None or rt.get("map_covariance") is None:
                missed[model].append((seed, e["id"], T.get("points"), rt.get("status"),
                                      rt.get("reason")))
                continue
            err = np.array(e["corner_in_map"]) - np.array(T["map"])
            C = np.array(rt["map_covariance"])
            rows[model].append((seed, e["id"], err,
                                err[:2] @ np.linalg.solve(C[:2, :2], err[:2]),
                                err @ np.linalg.solve(C, err)))

print(f"{seeds} seeds, {points} points, targets {dist} m from the road, {decoys} decoys, "
      f"a plain sign 0.4 m beside each board, {fmt}, "
      f"range noise {noise + ' m' if noise else 'synth default'}\n")
print("| model | found | horizontal median / max (mm) | 3D median / max (mm) | "
      "inside 95 % ellipse (2D) | inside ellipsoid (3D) | wrong object (> 5 cm) |")
print("|---|---|---|---|---|---|---|")
for model in ("l", "sphere", "board"):
    ok = rows[model]
    n = len(ok) + len(missed[model])
    if not ok:
        print(f"| {model} | 0 / {n} | | | | | |")
        continue
    eh = np.array([np.linalg.norm(x[2][:2]) for x in ok]) * 1e3
    e3 = np.array([np.linalg.norm(x[2]) for x in ok]) * 1e3
    c2 = sum(x[3] < 5.991 for x in ok)
    c3 = sum(x[4] < 7.815 for x in ok)
    wrong = sum(x > 50 for x in eh)
    print(f"| {model} | {len(ok)} / {n} | {np.median(eh):.2f} / {eh.max():.2f} | "
          f"{np.median(e3):.2f} / {e3.max():.2f} | {c2} / {len(ok)} ({100 * c2 / len(ok):.1f} %) | "
          f"{c3} / {len(ok)} ({100 * c3 / len(ok):.1f} %) | {wrong} |")
print()
for model in ("l", "sphere", "board"):
    for s, i, pts, status, reason in missed[model]:
        print(f"not located: {model} seed {s} target {i} ({pts} returns in truth): {status}: {reason}")
    for s, i, err, c2, c3 in sorted(rows[model], key=lambda x: -np.linalg.norm(x[2]))[:3]:
        print(f"largest {model}: seed {s} target {i}: {np.round(err * 1e3, 2)} mm, "
              f"chi2_2 {c2:.1f}, chi2_3 {c3:.1f}")
