#!/usr/bin/env python3
"""How well an L's height is placed and covered when its plates are seen in
part (docs/uncertainty.md, "Height seen"): target 1 behind a barrier or in
grass, seeds 1-6, and every target of an open scene, seeds 1-8; 2 M points,
`synth --config` with `[obstacles]`, `eval --no-report`. Per case: the
located height less the true mid plate height (dz), its sigma_z (from
result.json's map_covariance), |dz|/sigma_z, and how many targets the run's
height warning names.

Usage: bench/heights_table.py BIN [CASE...]    (needs numpy; CASE: a word of
the cases to run, all by default)
"""
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

binary = sys.argv[1]
# (label, synth config, seeds, targets scored: None for all)
CASES = [
    ("lower 40 % hidden", "[obstacles]\nhide_lower = 0.4\n", range(1, 7), {"1"}),
    ("lower 60 % hidden", "[obstacles]\nhide_lower = 0.6\n", range(1, 7), {"1"}),
    ("grass 0.25 m", "[obstacles]\ngrass_m = 0.25\n", range(1, 7), {"1"}),
    ("grass 0.4 m", "[obstacles]\ngrass_m = 0.4\n", range(1, 7), {"1"}),
    ("no obstacle, all targets", "", range(1, 9), None),
    # Spans taller than the configured 0.6 m plates: plates built taller,
    # and every target mapped twice 4 cm apart in height (a loop closed
    # badly; the truth is the first pass's).
    ("plates 0.66 m tall, all targets", "[target]\nplate_height_m = 0.66\n", range(1, 5), None),
    ("plates 0.68 m tall, all targets", "[target]\nplate_height_m = 0.68\n", range(1, 5), None),
    ("mapped twice 4 cm apart in z, all targets",
     "[second_pass]\nshare = 1.0\noffset_m = [0.0, 0.0, 0.04]\n", range(1, 5), None),
]
ONLY = set(sys.argv[2:])


def named(warnings, target):
    """Whether a height warning ("the height(s) of target(s) 1, 4 ...
    uncertain by", "the ground around target(s) 1, 4 shows two thin layers")
    names `target`."""
    for w in warnings:
        for prefix in ("the height of target ", "the heights of targets ",
                       "the ground around target ", "the ground around targets "):
            if w.startswith(prefix) and " uncertain by" in w:
                ids = w[len(prefix):].split(" uncertain by")[0].split(" shows two thin layers")[0]
                ids = ids.replace(" is", "").replace(" are", "").replace(",", " ").split()
                if target in ids:
                    return True
    return False


print("| case | dz | median abs(dz) | sigma_z | abs(dz)/sigma_z | named |")
print("|---|---|---|---|---|---|")
for case, toml, seeds, ids in CASES:
    if ONLY and not any(o in case for o in ONLY):
        continue
    dz, sz, told = [], [], 0
    for seed in seeds:
        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            cfg = d / "o.toml"
            cfg.write_text(toml)
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
    print(f"| {case} | {min(dz):+.0f} to {max(dz):+.0f} mm | "
          f"{np.median(np.abs(dz)):.0f} mm | {min(sz):.0f}-{max(sz):.0f} mm | "
          f"max {z.max():.2f}, {int(sum(z > 1.96))} of {len(z)} beyond 1.96 | {told} of {len(z)} |",
          flush=True)
