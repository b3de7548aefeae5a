#!/usr/bin/env python3
"""Writes a float32 copy of a binary PCD with double x y z (mapgauge's output),
for PCL's command-line tools: their PCLPointCloud2 filters read every field as
float32, so on double maps they silently select nothing.

Usage: pcd_f32.py IN.pcd OUT.pcd
"""
import sys

import numpy as np


def main() -> int:
    src, dst = sys.argv[1:3]
    with open(src, "rb") as f:
        head = b""
        while not head.endswith(b"DATA binary\n"):
            line = f.readline()
            if not line:
                print(f"error: {src}: not a binary PCD", file=sys.stderr)
                return 1
            head += line
        fields = [l for l in head.split(b"\n") if l.startswith(b"FIELDS")]
        sizes = [l for l in head.split(b"\n") if l.startswith(b"SIZE")]
        if fields != [b"FIELDS x y z"] or sizes != [b"SIZE 8 8 8"]:
            print(f"error: {src}: expected FIELDS x y z, SIZE 8 8 8", file=sys.stderr)
            return 1
        n = int([l for l in head.split(b"\n") if l.startswith(b"POINTS")][0].split()[1])
        with open(dst, "wb") as out:
            out.write(
                (
                    "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\n"
                    f"SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {n}\nHEIGHT 1\n"
                    f"VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n"
                ).encode()
            )
            left = n
            while left > 0:
                k = min(left, 1 << 20)
                a = np.frombuffer(f.read(k * 24), dtype="<f8")
                out.write(a.astype("<f4").tobytes())
                left -= k
    return 0


if __name__ == "__main__":
    sys.exit(main())
