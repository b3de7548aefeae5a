#!/usr/bin/env python3
"""Writes a LAS 1.4 LAZ file of point format 6 or 7 (as aerial and mobile
mapping deliver) from the points of a LAS file mapgauge wrote, with laspy
(PyPI: `pip install "laspy[lazrs]"`): mapgauge itself writes LAS 1.2 format 0.

    laz14_write.py IN.las OUT.laz [FORMAT]     # FORMAT 6 (default) or 7

The coordinates (integers, scales, offsets) are kept; the other fields vary
as a scanner's do (increasing GPS time, 1-3 returns, intensity, scan angle,
classification, four scanner channels, and RGB for format 7), so every layer
of the compressed file holds data a reader must decode or skip. Written in
blocks of 1 M points, so memory stays small at any size.
"""

import sys

import laspy
import numpy as np


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    src, dst = sys.argv[1], sys.argv[2]
    fmt = int(sys.argv[3]) if len(sys.argv) == 4 else 6
    if fmt not in (6, 7):
        sys.exit("FORMAT must be 6 or 7")
    rng = np.random.default_rng(21)
    with laspy.open(src) as r:
        hdr = laspy.LasHeader(point_format=fmt, version="1.4")
        hdr.scales = r.header.scales
        hdr.offsets = r.header.offsets
        done = 0
        with laspy.open(dst, mode="w", header=hdr, do_compress=True) as w:
            for pts in r.chunk_iterator(1_000_000):
                n = len(pts)
                rec = laspy.ScaleAwarePointRecord.zeros(n, header=hdr)
                rec.X, rec.Y, rec.Z = pts.X, pts.Y, pts.Z
                idx = np.arange(done, done + n)
                rec.gps_time = 1.0e8 + idx * 1e-5 + rng.random(n) * 1e-6
                returns = rng.integers(1, 4, n)
                rec.number_of_returns = returns
                rec.return_number = rng.integers(0, 3, n) % returns + 1
                rec.intensity = rng.integers(0, 4096, n)
                rec.scan_angle = rng.integers(-3000, 3000, n)
                rec.classification = rng.choice([1, 2, 5, 6], n)
                rec.scanner_channel = (idx // 10_000) % 4
                rec.point_source_id = (idx // 1_000_000) % 7
                if fmt == 7:
                    rec.red = rng.integers(0, 65536, n)
                    rec.green = rng.integers(0, 65536, n)
                    rec.blue = rng.integers(0, 65536, n)
                w.write_points(rec)
                done += n
    print(f"{dst}: {done} points, LAS 1.4 point format {fmt}", file=sys.stderr)


if __name__ == "__main__":
    main()
