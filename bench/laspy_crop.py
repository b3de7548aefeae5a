#!/usr/bin/env python3
"""The laspy baseline of bench/run.sh for LAS/LAZ (and COPC, read as LAZ):
what `mapgauge crop` does, in laspy (PyPI: `pip install "laspy[lazrs]"`).

Reads the whole map with laspy.read (LAZ decoded by lazrs, on every core),
keeps the points within RADIUS (horizontal distance, a vertical cylinder as
mapgauge's default) of each surveyed target with a numpy mask, and writes one
LAS per target (all fields, as laspy keeps them).

Usage: laspy_crop.py MAP SURVEY.csv OUTDIR [RADIUS]
"""
import csv
import os
import sys

import laspy
import numpy as np


def main() -> int:
    if len(sys.argv) < 4:
        print(__doc__, file=sys.stderr)
        return 2
    path, survey, out = sys.argv[1:4]
    radius = float(sys.argv[4]) if len(sys.argv) > 4 else 5.0
    with open(survey, newline="") as f:
        targets = [(r["id"], float(r["x"]), float(r["y"])) for r in csv.DictReader(f)]
    las = laspy.read(path, laz_backend=laspy.LazBackend.LazrsParallel) if path.endswith(".laz") else laspy.read(path)
    x, y = np.asarray(las.x), np.asarray(las.y)
    if len(x) == 0:
        print(f"error: {path}: laspy read no points", file=sys.stderr)
        return 1
    os.makedirs(out, exist_ok=True)
    r2 = radius * radius
    for tid, tx, ty in targets:
        mask = (x - tx) ** 2 + (y - ty) ** 2 < r2
        # A fresh header of the same point format: laspy writes no COPC, and
        # a crop is no octree.
        head = laspy.LasHeader(point_format=las.header.point_format, version=las.header.version)
        head.scales, head.offsets = las.header.scales, las.header.offsets
        crop = laspy.LasData(head)
        crop.points = las.points[mask]
        crop.write(os.path.join(out, f"{tid}.las"))
        print(f"{tid} {int(mask.sum())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
