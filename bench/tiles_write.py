#!/usr/bin/env python3
"""Writes an Autoware tiled point-cloud map (a folder of binary PCD tiles and
`pointcloud_map_metadata.yaml`) from a double binary PCD that mapgauge wrote
(`FIELDS x y z`, `SIZE 8 8 8`), for bench/run.sh's `tiles` format. Cuts as
Autoware's `pointcloud_divider` and mapgauge's `cloud::write_tiles` do: tile
`<ix>_<iy>.pcd` holds the points with floor(x / RES) = ix, floor(y / RES) = iy,
in their input order; tiles in row-then-column order. Needs numpy.

    tiles_write.py MAP.pcd OUTDIR [RES]      # RES metres, default 20
"""

import os
import sys

import numpy as np


def read_pcd(path):
    with open(path, "rb") as f:
        head = {}
        while True:
            line = f.readline()
            if not line:
                sys.exit(f"{path}: no DATA line")
            if line.startswith(b"#"):
                continue
            key, _, val = line.decode().strip().partition(" ")
            head[key] = val
            if key == "DATA":
                break
        if head.get("FIELDS") != "x y z" or head.get("SIZE") != "8 8 8" or head["DATA"] != "binary":
            sys.exit(f"{path}: want a binary PCD of x y z doubles, got {head}")
        n = int(head["POINTS"])
        return np.fromfile(f, dtype="<f8", count=3 * n).reshape(n, 3)


def write_pcd(path, pts):
    head = (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\n"
        "SIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\n"
        f"WIDTH {len(pts)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(pts)}\nDATA binary\n"
    )
    with open(path, "wb") as f:
        f.write(head.encode())
        f.write(np.ascontiguousarray(pts, dtype="<f8").tobytes())


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    src, out = sys.argv[1], sys.argv[2]
    res = float(sys.argv[3]) if len(sys.argv) == 4 else 20.0
    pts = read_pcd(src)
    ix = np.floor(pts[:, 0] / res).astype(np.int64)
    iy = np.floor(pts[:, 1] / res).astype(np.int64)
    # Stable sort by (iy, ix): each tile keeps its points' input order.
    order = np.lexsort((ix, iy))
    keys = np.stack([iy[order], ix[order]], axis=1)
    cut = np.flatnonzero(np.any(keys[1:] != keys[:-1], axis=1)) + 1
    os.makedirs(out, exist_ok=True)
    yaml = [f"x_resolution: {res!r}", f"y_resolution: {res!r}"]
    for idx in np.split(order, cut):
        cx, cy = int(ix[idx[0]]), int(iy[idx[0]])
        name = f"{cx}_{cy}.pcd"
        write_pcd(os.path.join(out, name), pts[idx])
        yaml.append(f"{name}: [{cx * res!r}, {cy * res!r}]")
    with open(os.path.join(out, "pointcloud_map_metadata.yaml"), "w") as f:
        f.write("\n".join(yaml) + "\n")
    print(f"{out}: {len(pts)} points in {len(cut) + 1} tiles of {res} m", file=sys.stderr)


if __name__ == "__main__":
    main()
