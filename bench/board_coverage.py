#!/usr/bin/env python3
"""Checkerboard boards over synthetic scenes (issue 33): found, error, and how
often the crossing's 95 % ellipse (horizontal, chi2_2 = 5.991) and ellipsoid
(3D, chi2_3 = 7.815) hold the truth.

Usage: bench/board_coverage.py BIN FIRST_SEED END_SEED POINTS [synth flags...]
  e.g. bench/board_coverage.py target/release/mapgauge 1 25 3000000
       bench/board_coverage.py target/release/mapgauge 1 13 3000000 --config far.toml
Each seed: `synth --models board --format pcd-xyzi` (5 boards), `eval
--no-report`, then each board's located crossing (eval.targets[].corner_in_map,
the map's own frame) against truth.json's map position, with result.json's
map_covariance. Scenes go to /tmp/board-coverage/SEED. Needs numpy.
FORMAT=laz (or las, ply-f32, pcd-fastlio) writes the map in that format
instead: the intensity read from it.
"""
import json
import os
import subprocess
import sys

import numpy as np

B = sys.argv[1]
seeds = range(int(sys.argv[2]), int(sys.argv[3]))
points = sys.argv[4]
extra = sys.argv[5:]
fmt = os.environ.get("FORMAT", "pcd-xyzi")
ext = {"laz": "laz", "las": "las", "ply-f32": "ply"}.get(fmt, "pcd")
rows = []
for s in seeds:
    d = f"/tmp/board-coverage/{s}"
    subprocess.run(["rm", "-rf", d])
    subprocess.run([B, "synth", "--out", d, "--points", points, "--models", "board",
                    "--format", fmt, "--seed", str(s)] + extra,
                   check=True, capture_output=True)
    subprocess.run([B, "eval", "--map", f"{d}/map.{ext}", "--survey", d + "/survey.csv",
                    "--out", d + "/out", "--no-report"], capture_output=True)
    t = json.load(open(d + "/truth.json"))
    if not os.path.exists(d + "/out/result.json"):
        # eval found none: every board not found (failed.csv says why).
        why = open(d + "/out/failed.csv").read().splitlines()[1:]
        for x, w in zip(t["targets"], why + [""] * len(t["targets"])):
            rows.append((s, x["id"], None, None, None, x.get("points"), w[-160:]))
        continue
    r = json.load(open(d + "/out/result.json"))
    tt = {x["id"]: x for x in t["targets"]}
    for e, rt in zip(r["eval"]["targets"], r["targets"]):
        T = tt[e["id"]]
        if e.get("corner_in_map") is None:
            rows.append((s, e["id"], None, None, None, T.get("points"), rt["reason"]))
            continue
        err = np.array(e["corner_in_map"]) - np.array(T["map"])
        C = np.array(rt["map_covariance"])
        rows.append((s, e["id"], err, err[:2] @ np.linalg.solve(C[:2, :2], err[:2]),
                     err @ np.linalg.solve(C, err), e["board"]["points"], None))
ok = [r for r in rows if r[2] is not None]
print(f"found {len(ok)} of {len(rows)}")
for r in rows:
    if r[2] is None:
        print(f"  not found: seed {r[0]} target {r[1]} ({r[5]} returns in truth): {r[6]}")
e3 = np.array([np.linalg.norm(r[2]) for r in ok])
eh = np.array([np.linalg.norm(r[2][:2]) for r in ok])
print("error mm: horizontal median %.2f max %.2f; 3D median %.2f max %.2f"
      % (1e3 * np.median(eh), 1e3 * eh.max(), 1e3 * np.median(e3), 1e3 * e3.max()))
c2 = np.array([r[3] for r in ok])
c3 = np.array([r[4] for r in ok])
print("inside the 95 %% ellipse (2D) %d/%d, ellipsoid (3D) %d/%d"
      % ((c2 < 5.991).sum(), len(ok), (c3 < 7.815).sum(), len(ok)))
print("board points: median %d, least %d" % (np.median([r[5] for r in ok]), min(r[5] for r in ok)))
print("largest errors:")
for r in sorted(ok, key=lambda r: -np.linalg.norm(r[2]))[:5]:
    print("  seed %d target %s: %s mm, chi2_3 %.1f, %d points"
          % (r[0], r[1], np.round(r[2] * 1e3, 2), r[4], r[5]))
