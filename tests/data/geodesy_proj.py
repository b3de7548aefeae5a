# Independent WGS84 values for src/survey/geodesy.rs tests, from PROJ via pyproj.
from pyproj import Transformer
import pyproj
print("# pyproj", pyproj.__version__, "PROJ", pyproj.proj_version_str)
to_ecef = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
print("ECEF")
for lat, lon, h in [(36.3725, 127.3631, 70.0), (-33.9249, 18.4241, 10.0), (40.0, -105.0, 1600.0), (-45.0, -70.5, -30.0), (0.0, 0.0, 0.0)]:
    x, y, z = to_ecef.transform(lon, lat, h)
    print(f"({lat!r}, {lon!r}, {h!r}) -> ({x!r}, {y!r}, {z!r})")
print("ENU")
cases = [
    ((36.3725, 127.3631, 70.0), (36.3735, 127.365, 75.5)),     # NE of the demo origin
    ((36.3725, 127.3631, 70.0), (36.371, 127.3612, 64.0)),     # SW
    ((-33.9249, 18.4241, 10.0), (-33.93, 18.43, 15.0)),        # SE, southern hemisphere
    ((40.0, -105.0, 1600.0), (39.99, -105.02, 1590.0)),        # SW, western hemisphere
    ((0.001, -0.002, 0.0), (-0.05, 0.06, 12.0)),               # across the equator and Greenwich
    ((52.0, 4.5, 40.0), (52.15, 4.75, 45.0)),                  # ~24 km: curvature matters
]
for o, p in cases:
    t = Transformer.from_pipeline(
        f"+proj=pipeline +step +proj=axisswap +order=2,1 +step +proj=unitconvert +xy_in=deg +xy_out=rad "
        f"+step +proj=cart +ellps=WGS84 +step +proj=topocentric +ellps=WGS84 +lat_0={o[0]} +lon_0={o[1]} +h_0={o[2]}")
    e, n, u = t.transform(p[0], p[1], p[2])
    print(f"{o!r} {p!r} -> ({e!r}, {n!r}, {u!r})")
