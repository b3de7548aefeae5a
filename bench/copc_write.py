#!/usr/bin/env python3
"""Writes a COPC file (LAS 1.4 point format 6, LAZ-compressed octree nodes)
with copclib (PyPI: `pip install copclib numpy`), for mapgauge's COPC tests
and benchmark: mapgauge itself writes no COPC.

    copc_write.py IN.las OUT.copc.laz   # the points of a LAS file mapgauge wrote
    copc_write.py --random N SEED OUT.copc.laz

COPC_MAX_NODE (default 20000) sets the points a leaf holds about.

The octree is built here (copclib writes the nodes it is given): a depth at
which leaves hold about MAX_NODE points, and each point on a level of detail
drawn from a hash of its index (1/8 of the points of a level go one level up),
so every level has nodes of similar size, as real writers (untwine, PDAL) do.
Nodes are written in (level, x, y, z) order; points keep their input order
within a node.
"""

import os
import sys

import numpy as np
import copclib as copc

MAX_NODE = int(os.environ.get("COPC_MAX_NODE", "20000"))


def read_las(path):
    """Integer coordinates, scales and offsets of a LAS file (any version)."""
    head = np.fromfile(path, dtype=np.uint8, count=375)
    u32 = lambda o: int(head[o : o + 4].view("<u4")[0])
    start = u32(96)
    rec = int(head[105:107].view("<u2")[0])
    count = u32(107)
    if count == 0 and head[25] >= 4:
        count = int(head[247:255].view("<u8")[0])
    scale = head[131:155].view("<f8").copy()
    offset = head[155:179].view("<f8").copy()
    raw = np.memmap(path, dtype=np.uint8, mode="r", offset=start, shape=(count, rec))
    xyz = np.ascontiguousarray(raw[:, :12]).view("<i4").reshape(count, 3)
    return xyz, scale, offset


def random_cloud(n, seed):
    """A 400 m x 400 m x 20 m cloud at UTM-like coordinates, millimetre grid."""
    rng = np.random.default_rng(seed)
    xyz = np.empty((n, 3), dtype=np.int32)
    xyz[:, 0] = rng.integers(0, 400_000, n)
    xyz[:, 1] = rng.integers(0, 400_000, n)
    xyz[:, 2] = rng.integers(0, 20_000, n)
    return xyz, np.array([0.001] * 3), np.array([350_000.0, 4_150_000.0, 0.0])


def write(xyz, scale, offset, out):
    n = len(xyz)
    pos = xyz * scale + offset
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    centre = (lo + hi) / 2
    half = float((hi - lo).max()) / 2 * 1.0001 + 1e-3
    depth = 0
    while n > MAX_NODE * 8**depth and depth < 12:
        depth += 1
    cells = 1 << depth
    leaf = np.floor((pos - (centre - half)) / (2 * half / cells)).astype(np.int64)
    np.clip(leaf, 0, cells - 1, out=leaf)
    # Level of detail: trailing zero bits of a multiplicative hash, 3 per level.
    h = (np.arange(n, dtype=np.uint64) + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15)
    tz = np.zeros(n, dtype=np.int64)
    for b in range(3 * depth):
        tz += (h & np.uint64((1 << (b + 1)) - 1)) == 0
    level = depth - np.minimum(depth, tz // 3)
    key = leaf >> (depth - level)[:, None]
    order = np.lexsort((np.arange(n), key[:, 2], key[:, 1], key[:, 0], level))

    cfg = copc.CopcConfigWriter(6, copc.Vector3(*scale), copc.Vector3(*offset))
    cfg.las_header.min = copc.Vector3(*lo)
    cfg.las_header.max = copc.Vector3(*hi)
    cfg.copc_info.center_x, cfg.copc_info.center_y, cfg.copc_info.center_z = centre
    cfg.copc_info.halfsize = half
    cfg.copc_info.spacing = 2 * half / 128
    w = copc.FileWriter(out, cfg)
    rec = np.dtype(
        [
            ("xyz", "<i4", 3),
            ("intensity", "<u2"),
            ("returns", "u1"),
            ("flags", "u1"),
            ("class", "u1"),
            ("user", "u1"),
            ("angle", "<i2"),
            ("source", "<u2"),
            ("time", "<f8"),
        ]
    )
    assert rec.itemsize == 30
    lk = np.column_stack([level[order], key[order]])
    bounds = np.flatnonzero(np.any(lk[1:] != lk[:-1], axis=1)) + 1
    for part in np.split(order, bounds):
        r = np.zeros(len(part), dtype=rec)
        r["xyz"] = xyz[part]
        r["intensity"] = (part % 4096).astype(np.uint16)
        r["returns"] = 0x11
        r["class"] = 1
        first = part[0]
        l = int(level[first])
        kx, ky, kz = (int(v) for v in key[first])
        w.AddNode(copc.VoxelKey(l, kx, ky, kz), copc.VectorChar(r.view(np.int8)))
    w.Close()
    print(f"{out}: {n} points, depth {depth}, {len(bounds) + 1} nodes")


def main(argv):
    if len(argv) == 5 and argv[1] == "--random":
        xyz, scale, offset = random_cloud(int(argv[2]), int(argv[3]))
        write(xyz, scale, offset, argv[4])
    elif len(argv) == 3:
        xyz, scale, offset = read_las(argv[1])
        write(xyz, scale, offset, argv[2])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv)
