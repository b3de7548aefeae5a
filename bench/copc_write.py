#!/usr/bin/env python3
"""Writes a COPC file (LAS 1.4 point format 6, LAZ-compressed octree nodes)
with copclib (PyPI: `pip install copclib numpy`), for mapgauge's COPC tests
and benchmark: mapgauge itself writes no COPC.

    copc_write.py IN.las OUT.copc.laz   # the points of a LAS file mapgauge wrote
    copc_write.py --random N SEED OUT.copc.laz

COPC_MAX_NODE (default 20000) sets the points a leaf holds about.
COPC_LEAF=N switches to an adaptive octree, as real writers build it (below).
COPC_KEEP="x,y,r;x,y,r..." keeps only a LAS file's points within r (m,
horizontally) of one of the (x, y) (a small test scene cut from a big one).

The octree is built here (copclib writes the nodes it is given): a depth at
which leaves hold about MAX_NODE points, and each point on a level of detail
drawn from a hash of its index (1/8 of the points of a level go one level up),
so every level has nodes of similar size, as real writers (untwine, PDAL) do.
Nodes are written in (level, x, y, z) order; points keep their input order
within a node. (The depth counts the whole octree cube: for a flat cloud such
as the random 400 m x 400 m x 20 m one, whose points fill about 1/20 of the
cube, nodes hold about ten times MAX_NODE points.)

With COPC_LEAF=N the octree is adaptive instead, split as untwine's and
PDAL's are: a node is split while its subtree holds more than N points (down
to ADAPTIVE_DEPTH), and a node that is split keeps about min(N,
COPC_NODE_KEEP) (default 16384, a 128 x 128 grid's worth of a surface) of
the points that reach it; a leaf keeps every point that reaches it. Dense
places go deep in small nodes, sparse ones stay shallow, so no node holds
more than about N points (PDAL's lone-star COPC, written by untwine, has
nodes of at most 127 k), save a leaf at ADAPTIVE_DEPTH. Unlike untwine,
which keeps one point per cell of a grid over the node, the points a node
keeps are drawn by a hash of the point's index and the level, so coarse
levels follow the points' density (over-represent a dense strip) rather
than spreading evenly. The subtree counts come from one more pass over the
points, binned at ADAPTIVE_DEPTH, holding a count per occupied cell (about
150 bytes each: a few GB for tens of millions of cells).

Streaming, so memory stays bounded (well under 1 GB at 200 M points with
the fixed depth; the adaptive mode's counts above come on top): the points
are read in slabs of CHUNK in input order three times (four when adaptive),
(1) for the
bounds, (2) to sort them into temporary bucket files next to OUT, one per
(level, node x), in input order, and (3) bucket by bucket, to sort each by
node and hand copclib one node at a time (copclib compresses and writes each
node as it comes and keeps only the hierarchy). The random cloud is drawn as
one numpy stream, all x, then all y, then all z; the generator states at the
starts of y and z are found in pass 1, so the points, the octree and the file
are the same as the former in-memory version wrote (byte for byte). The
temporary files take 20 bytes a point (4 GB at 200 M points).
"""

import os
import resource
import shutil
import sys

import numpy as np
import copclib as copc

MAX_NODE = int(os.environ.get("COPC_MAX_NODE", "20000"))
CHUNK = 4_000_000
MAX_BUCKETS = 256  # per level: node x columns are grouped beyond this
LEAF = int(os.environ.get("COPC_LEAF") or "0")
NODE_KEEP = min(int(os.environ.get("COPC_NODE_KEEP") or "16384"), LEAF or 1 << 62)
ADAPTIVE_DEPTH = 10


class LasSource:
    """Integer coordinates of a LAS file (any version), in slabs; with `keep`
    ((x, y, r) discs), only its points within r of one of them
    (horizontally), numbered in file order."""

    def __init__(self, path, keep=()):
        head = np.fromfile(path, dtype=np.uint8, count=375)
        u32 = lambda o: int(head[o : o + 4].view("<u4")[0])
        start = u32(96)
        rec = int(head[105:107].view("<u2")[0])
        count = u32(107)
        if count == 0 and head[25] >= 4:
            count = int(head[247:255].view("<u8")[0])
        self.scale = head[131:155].view("<f8").copy()
        self.offset = head[155:179].view("<f8").copy()
        self.n = count
        self.raw = np.memmap(path, dtype=np.uint8, mode="r", offset=start, shape=(count, rec))
        self.keep = keep
        if keep:
            self.n = sum(len(xyz) for _, xyz in self.slabs())

    def slabs(self):
        kept = 0
        for i in range(0, len(self.raw), CHUNK):
            part = self.raw[i : i + CHUNK, :12]
            xyz = np.ascontiguousarray(part).view("<i4").reshape(len(part), 3)
            if self.keep:
                x = xyz[:, 0] * self.scale[0] + self.offset[0]
                y = xyz[:, 1] * self.scale[1] + self.offset[1]
                near = np.zeros(len(xyz), dtype=bool)
                for cx, cy, r in self.keep:
                    near |= (x - cx) ** 2 + (y - cy) ** 2 < r * r
                xyz = xyz[near]
                if len(xyz) == 0:
                    continue
            yield (kept if self.keep else i), xyz
            kept += len(xyz)


class RandomSource:
    """A 400 m x 400 m x 20 m cloud at UTM-like coordinates, millimetre grid:
    `rng.integers` for all x, then all y, then all z (one generator)."""

    SPAN = (400_000, 400_000, 20_000)

    def __init__(self, n, seed):
        self.n = n
        self.scale = np.array([0.001] * 3)
        self.offset = np.array([350_000.0, 4_150_000.0, 0.0])
        rng = np.random.default_rng(seed)
        self.states = []
        for span in self.SPAN:
            self.states.append(rng.bit_generator.state)
            for i in range(0, n, CHUNK):
                rng.integers(0, span, min(CHUNK, n - i))

    def slabs(self):
        gens = []
        for state in self.states:
            g = np.random.default_rng()
            g.bit_generator.state = state
            gens.append(g)
        for i in range(0, self.n, CHUNK):
            c = min(CHUNK, self.n - i)
            xyz = np.empty((c, 3), dtype=np.int32)
            for a, (g, span) in enumerate(zip(gens, self.SPAN)):
                xyz[:, a] = g.integers(0, span, c)
            yield i, xyz


class Octree:
    def __init__(self, n, scale, offset, lo, hi, depth=None):
        self.scale, self.offset = scale, offset
        self.lo, self.hi = lo, hi
        self.centre = (lo + hi) / 2
        self.half = float((hi - lo).max()) / 2 * 1.0001 + 1e-3
        if depth is None:
            depth = 0
            while n > MAX_NODE * 8**depth and depth < 12:
                depth += 1
        self.depth = depth
        self.cells = 1 << depth
        # Buckets: per level, node x columns, grouped by 2**shift.
        self.shift = [max(0, l - MAX_BUCKETS.bit_length() + 1) for l in range(depth + 1)]
        first = np.cumsum([0] + [(1 << l) >> s for l, s in enumerate(self.shift)])
        self.first = first[:-1]
        self.buckets = int(first[-1])

    def level(self, index):
        """Level of detail: trailing zero bits of a multiplicative hash, 3 per level."""
        h = (index.astype(np.uint64) + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15)
        tz = np.zeros(len(index), dtype=np.int64)
        for b in range(3 * self.depth):
            tz += (h & np.uint64((1 << (b + 1)) - 1)) == 0
        return self.depth - np.minimum(self.depth, tz // 3)

    def key(self, xyz, level):
        pos = xyz * self.scale + self.offset
        leaf = np.floor((pos - (self.centre - self.half)) / (2 * self.half / self.cells)).astype(np.int64)
        np.clip(leaf, 0, self.cells - 1, out=leaf)
        return leaf >> (self.depth - level)[:, None]

    def bucket(self, level, kx):
        return self.first[level] + (kx >> np.asarray(self.shift)[level])


def packed(key, bits):
    """One int64 per (x, y, z) node key of `bits` bits an axis."""
    return (key[:, 0] << (2 * bits)) | (key[:, 1] << bits) | key[:, 2]


class Adaptive:
    """The adaptive octree's shape: per level, the sorted packed keys of its
    nodes and the chance a point reaching each one stays there."""

    def __init__(self, src, tree):
        d = tree.depth
        keys = np.empty(0, dtype=np.int64)
        counts = np.empty(0, dtype=np.int64)
        for _, xyz in src.slabs():
            k = packed(tree.key(xyz, np.full(len(xyz), d, dtype=np.int64)), d)
            k, n = np.unique(k, return_counts=True)
            keys = np.concatenate([keys, k])
            counts = np.concatenate([counts, n])
            keys, inv = np.unique(keys, return_inverse=True)
            counts = np.bincount(inv.ravel(), weights=counts, minlength=len(keys)).astype(np.int64)
        mask = (1 << d) - 1
        fine = np.stack([(keys >> (2 * d)) & mask, (keys >> d) & mask, keys & mask], axis=1)
        self.keys, self.keep = [], []
        reach_of_parent = None  # per node of the level above: q, the share of its subtree reaching it
        parent_keys = parent_split = parent_p = None
        for l in range(d + 1):
            k = packed(fine >> (d - l), l)
            lk, inv = np.unique(k, return_inverse=True)
            c = np.bincount(inv.ravel(), weights=counts, minlength=len(lk))
            if l == 0:
                q = np.ones(len(lk))
                exists = np.ones(len(lk), dtype=bool)
            else:
                mask_l = (1 << l) - 1
                xyz = np.stack([(lk >> (2 * l)) & mask_l, (lk >> l) & mask_l, lk & mask_l], axis=1)
                pk = packed(xyz >> 1, l - 1)
                at = np.searchsorted(parent_keys, pk)
                exists = parent_split[at]
                q = reach_of_parent[at] * (1 - parent_p[at])
            split = exists & (c > LEAF) & (l < d)
            reach = c * q
            p = np.where(split, np.minimum(1.0, NODE_KEEP / np.maximum(reach, 1.0)), 1.0)
            p[~exists] = 0.0
            self.keys.append(lk)
            self.keep.append(p)
            parent_keys, parent_split, parent_p, reach_of_parent = lk, split, p, q
        self.tree = tree

    def level(self, index, xyz):
        """The level each point stays at: walked down from the root, it stays
        at a node with that node's chance (a hash of index and level)."""
        tree = self.tree
        d = tree.depth
        leaf = tree.key(xyz, np.full(len(xyz), d, dtype=np.int64))
        out = np.full(len(xyz), -1, dtype=np.int64)
        h0 = (index.astype(np.uint64) + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15)
        for l in range(d + 1):
            open_ = np.flatnonzero(out < 0)
            if len(open_) == 0:
                break
            k = packed(leaf[open_] >> (d - l), l)
            at = np.searchsorted(self.keys[l], k)
            p = self.keep[l][at]
            h = h0[open_] ^ np.uint64((l + 1) * 0xBF58476D1CE4E5B9 & 0xFFFFFFFFFFFFFFFF)
            h = (h ^ (h >> np.uint64(31))) * np.uint64(0x94D049BB133111EB)
            h ^= h >> np.uint64(29)
            u = (h >> np.uint64(11)).astype(np.float64) / float(1 << 53)
            out[open_[u < p]] = l
        assert (out >= 0).all()
        return out


BUCKET = np.dtype([("i", "<u8"), ("xyz", "<i4", 3)])
REC = np.dtype(
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
assert REC.itemsize == 30


def write(src, out):
    n = src.n
    # Pass 1: bounds (x * scale + offset is monotonic in x).
    imin = np.full(3, np.iinfo(np.int32).max, dtype=np.int64)
    imax = np.full(3, np.iinfo(np.int32).min, dtype=np.int64)
    for _, xyz in src.slabs():
        imin = np.minimum(imin, xyz.min(axis=0))
        imax = np.maximum(imax, xyz.max(axis=0))
    lo, hi = imin * src.scale + src.offset, imax * src.scale + src.offset
    tree = Octree(n, src.scale, src.offset, lo, hi, ADAPTIVE_DEPTH if LEAF else None)
    adaptive = Adaptive(src, tree) if LEAF else None

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and soft < tree.buckets + 64:
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, tree.buckets + 64), hard))
    tmp = out + ".buckets"
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)
    try:
        # Pass 2: into bucket files, in input order.
        files = [open(os.path.join(tmp, f"{b}"), "wb") for b in range(tree.buckets)]
        for i0, xyz in src.slabs():
            index = np.arange(i0, i0 + len(xyz), dtype=np.int64)
            level = adaptive.level(index, xyz) if adaptive else tree.level(index)
            b = tree.bucket(level, tree.key(xyz, level)[:, 0])
            order = np.argsort(b, kind="stable")
            recs = np.empty(len(xyz), dtype=BUCKET)
            recs["i"] = index[order]
            recs["xyz"] = xyz[order]
            bs = b[order]
            cuts = np.flatnonzero(bs[1:] != bs[:-1]) + 1
            for lo_, hi_ in zip(np.r_[0, cuts], np.r_[cuts, len(bs)]):
                files[bs[lo_]].write(recs[lo_:hi_].tobytes())
            del recs, order, bs, b, level, index, xyz
        for f in files:
            f.close()

        # Pass 3: bucket by bucket, node by node.
        cfg = copc.CopcConfigWriter(6, copc.Vector3(*src.scale), copc.Vector3(*src.offset))
        cfg.las_header.min = copc.Vector3(*lo)
        cfg.las_header.max = copc.Vector3(*hi)
        cfg.copc_info.center_x, cfg.copc_info.center_y, cfg.copc_info.center_z = tree.centre
        cfg.copc_info.halfsize = tree.half
        cfg.copc_info.spacing = 2 * tree.half / 128
        w = copc.FileWriter(out, cfg)
        nodes = 0
        written = 0
        biggest = 0
        deepest = 0
        for l in range(tree.depth + 1):
            for b in range(tree.first[l], tree.first[l] + ((1 << l) >> tree.shift[l])):
                path = os.path.join(tmp, f"{b}")
                recs = np.fromfile(path, dtype=BUCKET)
                os.remove(path)
                if len(recs) == 0:
                    continue
                m = len(recs)
                key = tree.key(recs["xyz"], np.full(m, l, dtype=np.int64))
                order = np.lexsort((key[:, 2], key[:, 1], key[:, 0]))  # stable: input order kept
                key = key[order]
                recs = recs[order]
                cuts = np.flatnonzero(np.any(key[1:] != key[:-1], axis=1)) + 1
                for s, e in zip(np.r_[0, cuts], np.r_[cuts, m]):
                    r = np.zeros(e - s, dtype=REC)
                    r["xyz"] = recs["xyz"][s:e]
                    r["intensity"] = (recs["i"][s:e] % 4096).astype(np.uint16)
                    r["returns"] = 0x11
                    r["class"] = 1
                    kx, ky, kz = (int(v) for v in key[s])
                    w.AddNode(copc.VoxelKey(l, kx, ky, kz), copc.VectorChar(r.view(np.int8)))
                    nodes += 1
                    written += e - s
                    biggest = max(biggest, e - s)
                    deepest = l
        w.Close()
        assert written == n, (written, n)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{out}: {n} points, depth {deepest}, {nodes} nodes, at most {biggest} points a node")


def main(argv):
    if len(argv) == 5 and argv[1] == "--random":
        write(RandomSource(int(argv[2]), int(argv[3])), argv[4])
    elif len(argv) == 3:
        keep = [tuple(float(v) for v in d.split(",")) for d in os.environ.get("COPC_KEEP", "").split(";") if d]
        write(LasSource(argv[1], keep), argv[2])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv)
