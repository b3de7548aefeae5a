#!/usr/bin/env python3
"""How well an L's height is placed and covered when its plates are seen in
part (docs/uncertainty.md, "Height seen"): target 1 behind a barrier or in
grass, seeds 1-6, and every target of an open scene, seeds 1-8; 2 M points,
`synth --config` with `[obstacles]`, `eval --no-report`. Per case: the
located height less the true mid plate height (dz), its sigma_z (from
result.json's map_covariance), |dz|/sigma_z, and how many targets the run's
height warning names.

Usage: bench/heights_table.py BIN    (needs numpy)
"""
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

binary = sys.argv[1]
CASES = [
    ("hide_lower = 0.4", range(1, 7), {"1"}),
    ("hide_lower = 0.6", range(1, 7), {"1"}),
    ("grass_m = 0.25", range(1, 7), {"1"}),
    ("grass_m = 0.4", range(1, 7), {"1"}),
    ("", range(1, 9), None),
]


def named(warnings, target):
    """Whether the height warning ("the height(s) of target(s) 1, 4 ...
    uncertain by") names `target`."""
    for w in warnings:
        for prefix in ("the height of target ", "the heights of targets "):
            if w.startswith(prefix) and " uncertain by" in w:
                ids = w[len(prefix):].split(" uncertain by")[0]
                ids = ids.replace(" is", "").replace(" are", "").replace(",", " ").split()
                if target in ids:
                    return True
    return False


print("| case | dz | median abs(dz) | sigma_z | abs(dz)/sigma_z | named |")
print("|---|---|---|---|---|---|")
for case, seeds, ids in CASES:
    dz, sz, told = [], [], 0
    for seed in seeds:
        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            cfg = d / "o.toml"
            cfg.write_text(f"[obstacles]\n{case}\n" if case else "")
            subprocess.run([binary, "synth", "--config", str(cfg), "--seed", str(seed),
                            "--points", "2000000", "--out", str(d / "s")],
                           check=True, capture_output=True)
            subprocess.run([binary, "eval", "--no-report", "--map", str(d / "s" / "map.ply"),
                            "--survey", str(d / "s" / "survey.csv"), "--out", str(d / "o")],
                           capture_output=True)
            r = json.loads((d / "o" / "result.json").read_text())
            truth = {t["id"]: t for t in json.loads((d / "s" / "truth.json").read_text())["targets"]}
            for e, rt in zip(r["eval"]["targets"], r["targets"]):
                if (ids and e["id"] not in ids) or e.get("corner_in_map") is None:
                    continue
                dz.append((e["corner_in_map"][2] - truth[e["id"]]["map"][2]) * 1e3)
                sz.append(math.sqrt(rt["map_covariance"][2][2]) * 1e3)
                told += named(r["warnings"], e["id"])
    z = np.abs(dz) / np.array(sz)
    print(f"| {case or 'no obstacle, all targets'} | {min(dz):+.0f} to {max(dz):+.0f} mm | "
          f"{np.median(np.abs(dz)):.0f} mm | {min(sz):.0f}-{max(sz):.0f} mm | "
          f"max {z.max():.2f}, {int(sum(z > 1.96))} of {len(z)} beyond 1.96 | {told} of {len(z)} |",
          flush=True)
