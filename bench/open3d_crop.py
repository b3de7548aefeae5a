#!/usr/bin/env python3
"""The Open3D baseline of bench/run.sh: what `mapgauge crop` does, in Open3D.

Reads the whole map with open3d.io.read_point_cloud, keeps the points within
RADIUS (horizontal distance, a vertical cylinder as mapgauge's default) of each
surveyed target with a numpy mask, and writes one binary PLY per target.

Usage: open3d_crop.py MAP SURVEY.csv OUTDIR [RADIUS]
"""
import csv
import os
import sys

import numpy as np
import open3d as o3d


def main() -> int:
    if len(sys.argv) < 4:
        print(__doc__, file=sys.stderr)
        return 2
    path, survey, out = sys.argv[1:4]
    radius = float(sys.argv[4]) if len(sys.argv) > 4 else 5.0
    with open(survey, newline="") as f:
        targets = [(r["id"], float(r["x"]), float(r["y"])) for r in csv.DictReader(f)]
    cloud = o3d.io.read_point_cloud(path)
    pts = np.asarray(cloud.points)
    if len(pts) == 0:
        print(f"error: {path}: Open3D read no points", file=sys.stderr)
        return 1
    os.makedirs(out, exist_ok=True)
    r2 = radius * radius
    for tid, x, y in targets:
        mask = (pts[:, 0] - x) ** 2 + (pts[:, 1] - y) ** 2 < r2
        crop = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts[mask]))
        o3d.io.write_point_cloud(os.path.join(out, f"{tid}.ply"), crop)
        print(f"{tid} {int(mask.sum())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
