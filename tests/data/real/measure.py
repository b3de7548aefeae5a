#!/usr/bin/env python3
"""Independent readers for the corpus: own numpy PCD/PTS/CSV parsers, laspy, plyfile, pye57.
Prints a JSON list, one entry per file: points, nan_points, min, max and the first finite
point (float64), as tests/data/real/manifest.json holds them."""
import json
import struct
import sys
from pathlib import Path

import numpy as np

TYPEMAP = {("F", 4): "<f4", ("F", 8): "<f8", ("I", 1): "<i1", ("I", 2): "<i2", ("I", 4): "<i4",
           ("I", 8): "<i8", ("U", 1): "<u1", ("U", 2): "<u2", ("U", 4): "<u4", ("U", 8): "<u8"}


def lzf_decompress(src: bytes, out_len: int) -> bytes:
    out = bytearray(out_len)
    ip = op = 0
    n = len(src)
    while ip < n:
        ctrl = src[ip]; ip += 1
        if ctrl < 32:  # literal run of ctrl+1 bytes
            ln = ctrl + 1
            out[op:op + ln] = src[ip:ip + ln]
            ip += ln; op += ln
        else:  # back reference
            ln = ctrl >> 5
            ref = op - ((ctrl & 0x1f) << 8) - 1
            if ln == 7:
                ln += src[ip]; ip += 1
            ref -= src[ip]; ip += 1
            ln += 2
            if ref < 0:
                raise ValueError("LZF: bad back reference")
            for _ in range(ln):  # may overlap, copy byte by byte
                out[op] = out[ref]; op += 1; ref += 1
    if op != out_len:
        raise ValueError(f"LZF: got {op} bytes, expected {out_len}")
    return bytes(out)


def read_pcd(path):
    raw = Path(path).read_bytes()
    hdr = {}
    pos = 0
    while True:
        nl = raw.index(b"\n", pos)
        line = raw[pos:nl].decode("ascii").strip()
        pos = nl + 1
        if not line or line.startswith("#"):
            continue
        key, *vals = line.split()
        hdr[key.upper()] = vals
        if key.upper() == "DATA":
            break
    fields = hdr["FIELDS"]
    sizes = [int(s) for s in hdr["SIZE"]]
    types = hdr["TYPE"]
    counts = [int(c) for c in hdr.get("COUNT", ["1"] * len(fields))]
    npts = int(hdr["POINTS"][0]) if "POINTS" in hdr else int(hdr["WIDTH"][0]) * int(hdr["HEIGHT"][0])
    mode = hdr["DATA"][0].lower()
    names = [f.lower() for f in fields]
    ix = [names.index(a) for a in ("x", "y", "z")]
    if mode == "ascii":
        text = raw[pos:].decode("ascii").split("\n")
        rows = [l.split() for l in text if l.strip()]
        # column offset of each field (COUNT expands columns)
        offs = np.cumsum([0] + counts)[:-1]
        arr = np.array([[float(r[offs[i]]) for i in ix] for r in rows[:npts]], dtype=np.float64)
        if len(arr) != npts:
            raise ValueError(f"ascii: {len(arr)} rows, header says {npts}")
        # Values are of the declared type (PCL reads TYPE F SIZE 4 text into
        # float32): round through it.
        xyz = np.stack([arr[:, k].astype(TYPEMAP[(types[i], sizes[i])]).astype(np.float64)
                        for k, i in enumerate(ix)], axis=1)
    else:
        dt = np.dtype([(f"f{i}", TYPEMAP[(t, s)], (c,)) if c > 1 else (f"f{i}", TYPEMAP[(t, s)])
                       for i, (t, s, c) in enumerate(zip(types, sizes, counts))])
        if mode == "binary":
            data = np.frombuffer(raw, dtype=dt, count=npts, offset=pos)
            cols = [data[f"f{i}"].astype(np.float64) for i in ix]
        elif mode == "binary_compressed":
            csize, usize = struct.unpack("<II", raw[pos:pos + 8])
            buf = lzf_decompress(raw[pos + 8:pos + 8 + csize], usize)
            # field-major (SoA) layout: each field's npts values stored contiguously
            cols_all = []
            off = 0
            for t, s, c in zip(types, sizes, counts):
                n = s * c * npts
                cols_all.append(np.frombuffer(buf, dtype=TYPEMAP[(t, s)], count=c * npts, offset=off))
                off += n
            if off != usize:
                raise ValueError(f"binary_compressed: fields use {off} of {usize} bytes")
            cols = [cols_all[i].astype(np.float64) for i in ix]
        else:
            raise ValueError("unknown DATA " + mode)
        xyz = np.stack(cols, axis=1)
    return xyz, f"pcd-{mode}"


def read_ply(path):
    from plyfile import PlyData
    p = PlyData.read(str(path))
    v = p["vertex"]
    for name in ("intensity", "scalar_intensity"):
        if name in v.data.dtype.names:
            INTENSITY[str(path)] = np.asarray(v[name], dtype=np.float64)
            break
    xyz = np.stack([np.asarray(v[a], dtype=np.float64) for a in ("x", "y", "z")], axis=1)
    return xyz, f"ply-{'ascii' if p.text else ('binary_big_endian' if p.byte_order == '>' else 'binary_little_endian')}"


def read_las(path):
    import laspy
    las = laspy.read(str(path))
    xyz = np.stack([np.asarray(las.x, dtype=np.float64), np.asarray(las.y, dtype=np.float64),
                    np.asarray(las.z, dtype=np.float64)], axis=1)
    h = las.header
    kind = "laz" if str(path).lower().endswith(".laz") else "las"
    INTENSITY[str(path)] = np.asarray(las.intensity, dtype=np.float64)
    return xyz, f"{kind} {h.version.major}.{h.version.minor} pf{h.point_format.id}"


def read_e57(path):
    import pye57
    e = pye57.E57(str(path))
    parts, inten = [], []
    for i in range(e.scan_count):
        d = e.read_scan(i, intensity=True, ignore_missing_fields=True, transform=True)
        parts.append(np.stack([np.asarray(d[k], dtype=np.float64)
                               for k in ("cartesianX", "cartesianY", "cartesianZ")], axis=1))
        if "intensity" in d:
            inten.append(np.asarray(d["intensity"], dtype=np.float64))
    # Intensities when every scan has them (mapgauge reads them so).
    if inten and len(inten) == e.scan_count:
        INTENSITY[str(path)] = np.concatenate(inten)
    return np.concatenate(parts), f"e57 ({e.scan_count} scan(s), pose applied)"


def read_pts(path):
    lines = Path(path).read_text().split("\n")
    n = int(lines[0].split()[0])
    rows = [l.split() for l in lines[1:] if l.strip()]
    if len(rows) != n:
        raise ValueError(f"pts: {len(rows)} rows, header says {n}")
    if rows and all(len(r) in (4, 7) for r in rows):
        INTENSITY[str(path)] = np.array([float(r[3]) for r in rows], dtype=np.float64)
    return np.array([[float(v) for v in r[:3]] for r in rows], dtype=np.float64), "pts (Leica text, count line + x y z i r g b)"


def read_csv(path):
    lines = Path(path).read_text().split("\n")
    head = [h.strip('"').lower() for h in lines[0].split(",")]
    ix = [head.index(a) for a in ("x", "y", "z")]
    rows = [l.split(",") for l in lines[1:] if l.strip()]
    return np.array([[float(r[i]) for i in ix] for r in rows], dtype=np.float64), "xyz text (CSV with quoted header)"


# Intensities of the files whose readers here read them (LAS/LAZ by laspy,
# PLY by plyfile, E57 by pye57, PTS's fourth value), by path.
INTENSITY = {}

READERS = {".pcd": read_pcd, ".ply": read_ply, ".las": read_las, ".laz": read_las, ".e57": read_e57,
           ".pts": read_pts, ".txt": read_csv, ".xyz": read_csv}


def stats(path):
    xyz, fmt = READERS[Path(path).suffix.lower()](path)
    nan = ~np.isfinite(xyz).all(axis=1)
    good = xyz[~nan]
    out = {"format": fmt, "points": int(len(xyz)), "nan_points": int(nan.sum()),
           "min": good.min(axis=0).tolist(), "max": good.max(axis=0).tolist(),
           "first": good[0].tolist()}
    i = INTENSITY.get(str(path))
    if i is not None:
        i = i[~nan]
        i = i[np.isfinite(i)]
        out["intensity"] = {"sum": float(i.sum()), "min": float(i.min()), "max": float(i.max()),
                            "first": float(i[0])}
    return out


if __name__ == "__main__":
    # One JSON list, as manifest.json (less its provenance fields): the
    # input of tests/integration/real_corpus.rs with MAPGAUGE_CORPUS.
    out = []
    for p in sys.argv[1:]:
        if Path(p).suffix.lower() not in READERS:
            continue
        try:
            out.append({"file": Path(p).name, **stats(p)})
        except Exception as ex:  # report, don't hide
            print(f"{p}: {type(ex).__name__}: {ex}", file=sys.stderr)
    print(json.dumps(out, indent=1))
