//! Primitives of the synthetic world and their ray intersections.
//!
//! Everything is analytic (boxes rotated about z, vertical cylinders, spheres,
//! perforated vertical plates) except the ground, a height field that is
//! intersected by conservative sphere tracing inside the slab that bounds it.

use nalgebra::Vector3;

/// A ray with unit direction; `inv` caches 1/d for slab tests.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    /// Origin.
    pub o: Vector3<f64>,
    /// Unit direction.
    pub d: Vector3<f64>,
    /// Component-wise inverse of `d` (infinite where `d` is zero).
    pub inv: Vector3<f64>,
}

impl Ray {
    /// Builds a ray; `d` must be a unit vector.
    pub fn new(o: Vector3<f64>, d: Vector3<f64>) -> Self {
        Ray {
            o,
            d,
            inv: Vector3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z),
        }
    }
    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> Vector3<f64> {
        self.o + self.d * t
    }
}

/// Axis-aligned bounding box, the broad phase of every object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vector3<f64>,
    /// Upper corner.
    pub max: Vector3<f64>,
}

impl Aabb {
    /// The empty box (the identity of [`Aabb::union`]).
    pub fn empty() -> Self {
        Aabb {
            min: Vector3::repeat(f64::INFINITY),
            max: Vector3::repeat(f64::NEG_INFINITY),
        }
    }
    /// Smallest box holding both.
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.inf(&o.min),
            max: self.max.sup(&o.max),
        }
    }
    /// Entry parameter of the ray into the box if it enters before `tmax`.
    #[inline]
    pub fn hit(&self, r: &Ray, tmax: f64) -> Option<f64> {
        let mut t0 = 0.0f64;
        let mut t1 = tmax;
        for k in 0..3 {
            let a = (self.min[k] - r.o[k]) * r.inv[k];
            let b = (self.max[k] - r.o[k]) * r.inv[k];
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            // NaN (0 * inf when the origin lies on a face) must not shrink the interval.
            if lo > t0 {
                t0 = lo;
            }
            if hi < t1 {
                t1 = hi;
            }
            if t0 > t1 {
                return None;
            }
        }
        Some(t0)
    }
    /// Euclidean distance from `p` to the box (0 inside).
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        let mut s = 0.0;
        for k in 0..3 {
            let d = (self.min[k] - p[k]).max(p[k] - self.max[k]).max(0.0);
            s += d * d;
        }
        s.sqrt()
    }
}

/// A solid primitive.
#[derive(Debug, Clone, PartialEq)]
pub enum Prim {
    /// A box rotated about the vertical axis.
    Box {
        /// Centre.
        c: Vector3<f64>,
        /// Half sizes along the box's own x, y, z.
        half: Vector3<f64>,
        /// Heading of the box's x axis, as (cos, sin).
        cs: (f64, f64),
    },
    /// A vertical solid cylinder (poles, GNSS antenna).
    VCyl {
        /// Axis x.
        x: f64,
        /// Axis y.
        y: f64,
        /// Radius.
        r: f64,
        /// Bottom.
        z0: f64,
        /// Top.
        z1: f64,
    },
    /// A sphere; `porosity` is the chance a ray passes through (foliage).
    Sphere {
        /// Centre.
        c: Vector3<f64>,
        /// Radius.
        r: f64,
        /// Probability in [0, 1) that a ray crossing the sphere is not returned.
        porosity: f64,
    },
    /// A zero-thickness vertical rectangle starting at a corner line, with a
    /// solid frame and a square grid of square holes (the grill mesh).
    Plate(Plate),
}

/// A perforated vertical plate (see [`Prim::Plate`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Plate {
    /// Corner line (x, y) where the plate starts.
    pub x: f64,
    /// Corner line y.
    pub y: f64,
    /// Unit horizontal direction along the plate, away from the corner.
    pub u: (f64, f64),
    /// Bottom edge height.
    pub z0: f64,
    /// Width along `u`.
    pub w: f64,
    /// Height.
    pub h: f64,
    /// Solid frame width around the mesh.
    pub frame: f64,
    /// Hole pitch of the mesh.
    pub pitch: f64,
    /// Side of a square hole (`hole < pitch`).
    pub hole: f64,
    /// Share of the rays striking metal that return (1: all); the rest pass
    /// through, as from a plate seen past foliage or at a grazing angle.
    pub keep: f64,
}

impl Plate {
    /// Whether the plate point at (s along u, v above the bottom) is metal.
    pub(crate) fn solid_at(&self, s: f64, v: f64) -> bool {
        if s < 0.0 || s > self.w || v < 0.0 || v > self.h {
            return false;
        }
        if s < self.frame || s > self.w - self.frame || v < self.frame || v > self.h - self.frame {
            return true;
        }
        let a = (s - self.frame).rem_euclid(self.pitch);
        let b = (v - self.frame).rem_euclid(self.pitch);
        !(a < self.hole && b < self.hole)
    }
}

/// A uniform number in [0, 1) from a hash key (per-ray, per-primitive randomness).
#[inline]
pub(crate) fn unit_from(key: u64) -> f64 {
    (splitmix(key) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// SplitMix64 finaliser: a cheap, well-mixed 64-bit hash.
#[inline]
pub(crate) fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

const EPS: f64 = 1e-9;

/// [`Prim::hit`] of a box: the slab test in the box's own frame, the ray
/// turned by minus the box's yaw (cheaper than turning the box).
#[inline]
fn box_hit(r: &Ray, c: &Vector3<f64>, half: &Vector3<f64>, (co, si): (f64, f64)) -> Option<f64> {
    let p = r.o - c;
    // Into the box frame: rotate by -yaw.
    let o = Vector3::new(co * p.x + si * p.y, -si * p.x + co * p.y, p.z);
    let d = Vector3::new(co * r.d.x + si * r.d.y, -si * r.d.x + co * r.d.y, r.d.z);
    let mut t0 = f64::NEG_INFINITY;
    let mut t1 = f64::INFINITY;
    for k in 0..3 {
        if d[k].abs() < 1e-15 {
            if o[k].abs() > half[k] {
                return None;
            }
            continue;
        }
        let a = (-half[k] - o[k]) / d[k];
        let b = (half[k] - o[k]) / d[k];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    if t0 > t1 || t1 <= EPS {
        return None;
    }
    Some(if t0 > EPS { t0 } else { t1 })
}

/// [`Prim::hit`] of a vertical cylinder of radius `rad` about `(x, y)`
/// between heights `z0` and `z1`: its side, then its caps (a ray from above
/// meets a pole's top first).
#[inline]
fn vcyl_hit(r: &Ray, (x, y): (f64, f64), rad: f64, (z0, z1): (f64, f64)) -> Option<f64> {
    let ox = r.o.x - x;
    let oy = r.o.y - y;
    let a = r.d.x * r.d.x + r.d.y * r.d.y;
    let mut best = f64::INFINITY;
    if a > 1e-15 {
        let b = ox * r.d.x + oy * r.d.y;
        let c = ox * ox + oy * oy - rad * rad;
        let disc = b * b - a * c;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            for t in [(-b - sq) / a, (-b + sq) / a] {
                if t > EPS {
                    let z = r.o.z + t * r.d.z;
                    if z >= z0 && z <= z1 {
                        best = best.min(t);
                        break;
                    }
                }
            }
        }
    }
    if r.d.z.abs() > 1e-15 {
        for zc in [z0, z1] {
            let t = (zc - r.o.z) / r.d.z;
            if t > EPS && t < best {
                let px = ox + t * r.d.x;
                let py = oy + t * r.d.y;
                if px * px + py * py <= rad * rad {
                    best = t;
                }
            }
        }
    }
    best.is_finite().then_some(best)
}

/// [`Prim::hit`] of a sphere; a porous one (foliage) lets the ray through
/// or returns it from inside, by the ray's `key`, so a bush is not a shell.
#[inline]
fn sphere_hit(r: &Ray, c: &Vector3<f64>, rad: f64, porosity: f64, key: u64) -> Option<f64> {
    let oc = r.o - c;
    let b = oc.dot(&r.d);
    let cc = oc.norm_squared() - rad * rad;
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let (t0, t1) = (-b - sq, -b + sq);
    if t1 <= EPS {
        return None;
    }
    let t0 = t0.max(EPS);
    if porosity <= 0.0 {
        return Some(t0);
    }
    // Foliage: the ray gets through with probability `porosity`;
    // otherwise it returns from a leaf somewhere in the front half.
    let u = unit_from(key);
    if u < porosity {
        return None;
    }
    let depth = unit_from(key ^ 0x5555_5555_5555_5555);
    Some(t0 + 0.5 * (t1 - t0) * depth)
}

impl Plate {
    /// [`Prim::hit`] of the plate: where the ray crosses its plane, if metal
    /// is there (not a hole) and the ray is one of the `keep` share returned.
    #[inline]
    fn hit(&self, r: &Ray, key: u64) -> Option<f64> {
        let p = self;
        // Normal (horizontal) of the plate plane.
        let (nx, ny) = (-p.u.1, p.u.0);
        let dn = r.d.x * nx + r.d.y * ny;
        if dn.abs() < 1e-12 {
            return None;
        }
        let t = ((p.x - r.o.x) * nx + (p.y - r.o.y) * ny) / dn;
        if t <= EPS {
            return None;
        }
        let q = r.at(t);
        let s = (q.x - p.x) * p.u.0 + (q.y - p.y) * p.u.1;
        let returned = p.keep >= 1.0 || unit_from(key ^ 0x3C3C_3C3C_3C3C_3C3C) < p.keep;
        (returned && p.solid_at(s, q.z - p.z0)).then_some(t)
    }
}

impl Prim {
    /// Nearest positive hit parameter, if any. `key` feeds porous primitives.
    pub fn hit(&self, r: &Ray, key: u64) -> Option<f64> {
        match self {
            Prim::Box { c, half, cs } => box_hit(r, c, half, *cs),
            Prim::VCyl {
                x,
                y,
                r: rad,
                z0,
                z1,
            } => vcyl_hit(r, (*x, *y), *rad, (*z0, *z1)),
            Prim::Sphere {
                c,
                r: rad,
                porosity,
            } => sphere_hit(r, c, *rad, *porosity, key),
            Prim::Plate(p) => p.hit(r, key),
        }
    }

    /// Bounding box.
    pub(crate) fn aabb(&self) -> Aabb {
        match self {
            Prim::Box { c, half, cs } => {
                let ex = cs.0.abs() * half.x + cs.1.abs() * half.y;
                let ey = cs.1.abs() * half.x + cs.0.abs() * half.y;
                let e = Vector3::new(ex, ey, half.z);
                Aabb {
                    min: c - e,
                    max: c + e,
                }
            }
            Prim::VCyl { x, y, r, z0, z1 } => Aabb {
                min: Vector3::new(x - r, y - r, *z0),
                max: Vector3::new(x + r, y + r, *z1),
            },
            Prim::Sphere { c, r, .. } => Aabb {
                min: c - Vector3::repeat(*r),
                max: c + Vector3::repeat(*r),
            },
            Prim::Plate(p) => {
                let ex = p.x + p.u.0 * p.w;
                let ey = p.y + p.u.1 * p.w;
                Aabb {
                    min: Vector3::new(p.x.min(ex), p.y.min(ey), p.z0),
                    max: Vector3::new(p.x.max(ex), p.y.max(ey), p.z0 + p.h),
                }
            }
        }
    }
}

/// One sinusoidal component of the ground's undulation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Wave {
    /// Wave vector x (rad/m).
    pub kx: f64,
    /// Wave vector y (rad/m).
    pub ky: f64,
    /// Amplitude (m).
    pub amp: f64,
    /// Phase (rad).
    pub phase: f64,
}

/// The ground: a sloped plane plus smooth undulation, z = h(x, y).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Ground {
    /// Height at (cx, cy).
    pub z0: f64,
    /// Reference point x of the plane.
    pub cx: f64,
    /// Reference point y of the plane.
    pub cy: f64,
    /// dz/dx of the plane.
    pub gx: f64,
    /// dz/dy of the plane.
    pub gy: f64,
    /// Undulation components.
    pub waves: Vec<Wave>,
}

impl Ground {
    /// Height of the ground at (x, y).
    #[inline]
    pub fn height(&self, x: f64, y: f64) -> f64 {
        self.plane(x, y) + self.undulation(x, y)
    }
    #[inline]
    fn plane(&self, x: f64, y: f64) -> f64 {
        self.z0 + self.gx * (x - self.cx) + self.gy * (y - self.cy)
    }
    #[inline]
    fn undulation(&self, x: f64, y: f64) -> f64 {
        self.waves
            .iter()
            .map(|w| w.amp * (w.kx * x + w.ky * y + w.phase).sin())
            .sum()
    }
    /// Bound on |undulation|.
    fn amp_bound(&self) -> f64 {
        self.waves.iter().map(|w| w.amp.abs()).sum()
    }
    /// Bound on the undulation's horizontal gradient norm.
    fn grad_bound(&self) -> f64 {
        self.waves
            .iter()
            .map(|w| w.amp.abs() * w.kx.hypot(w.ky))
            .sum()
    }

    /// First intersection of the ray with the ground before `tmax`.
    ///
    /// The ground lies in the slab |z − plane| ≤ A; only that part of the ray
    /// is searched, by sphere tracing with the Lipschitz bound of the height
    /// above ground along the ray, so no crossing is ever stepped over.
    pub fn hit(&self, r: &Ray, tmax: f64) -> Option<f64> {
        let a = self.amp_bound();
        let l0 = r.o.z - self.plane(r.o.x, r.o.y);
        let m = r.d.z - self.gx * r.d.x - self.gy * r.d.y;
        let (t_start, t_end) = if l0 > a {
            if m >= 0.0 {
                return None;
            }
            ((a - l0) / m, (-a - l0) / m)
        } else if m < 0.0 {
            (0.0, (-a - l0) / m)
        } else {
            (0.0, tmax)
        };
        let t_end = t_end.min(tmax);
        if t_start > t_end {
            return None;
        }
        // Along the ray every wave's phase is linear in t: precompute it, and bound
        // the rate at which the height above ground can fall along this very ray.
        const MAXW: usize = 8;
        let mut wv = [(0.0f64, 0.0f64, 0.0f64); MAXW];
        let n = self.waves.len();
        if n > MAXW {
            return self.hit_generic(r, t_start, t_end, tmax);
        }
        let mut slope_bound = 0.0;
        for (slot, w) in wv.iter_mut().zip(&self.waves) {
            let om = w.kx * r.d.x + w.ky * r.d.y;
            *slot = (w.amp, w.kx * r.o.x + w.ky * r.o.y + w.phase, om);
            slope_bound += (w.amp * om).abs();
        }
        let wv = &wv[..n];
        let rate = (slope_bound - m).max(1e-6);
        let f = |t: f64| {
            l0 + m * t
                - wv.iter()
                    .map(|&(a, p, om)| a * (p + om * t).sin())
                    .sum::<f64>()
        };
        let mut t = t_start;
        for _ in 0..512 {
            let h = f(t);
            if h < TOL {
                return (t <= tmax).then_some(t);
            }
            t += h / rate;
            if t > t_end {
                return None;
            }
        }
        // Extremely grazing ray: accept where the march stopped.
        (t <= tmax).then_some(t)
    }

    /// Sphere tracing with the global gradient bound (any number of waves).
    fn hit_generic(&self, r: &Ray, t_start: f64, t_end: f64, tmax: f64) -> Option<f64> {
        let m = r.d.z - self.gx * r.d.x - self.gy * r.d.y;
        let rate = (self.grad_bound() * r.d.x.hypot(r.d.y) - m).max(1e-6);
        let mut t = t_start;
        for _ in 0..512 {
            let p = r.at(t);
            let f = p.z - self.height(p.x, p.y);
            if f < TOL {
                return (t <= tmax).then_some(t);
            }
            t += f / rate;
            if t > t_end {
                return None;
            }
        }
        (t <= tmax).then_some(t)
    }
}

/// Height above ground at which a ray counts as having reached it, metres.
const TOL: f64 = 5e-4;

/// A group of primitives behind one bounding box (a target, a car, a bush).
#[derive(Debug, Clone)]
pub struct Object {
    /// Broad-phase box.
    pub aabb: Aabb,
    /// The solids.
    pub prims: Vec<Prim>,
}

impl Object {
    /// Groups primitives, computing their common box.
    pub fn new(prims: Vec<Prim>) -> Self {
        let aabb = prims.iter().fold(Aabb::empty(), |b, p| b.union(&p.aabb()));
        Object { aabb, prims }
    }
}

/// Everything a ray can hit.
#[derive(Debug, Clone)]
pub struct World {
    /// The terrain.
    pub ground: Ground,
    /// Targets first (index = target index), then clutter.
    pub objects: Vec<Object>,
}

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter (range, for a unit direction).
    pub t: f64,
    /// Index into [`World::objects`], or `None` for the ground.
    pub object: Option<u32>,
    /// Index into the object's [`Object::prims`] (0 for the ground).
    pub prim: u32,
}

impl World {
    /// Nearest hit before `tmax`, testing only the objects listed in `active`
    /// (the per-scan broad phase) and then the ground up to that distance.
    pub fn cast(&self, r: &Ray, tmax: f64, active: &[u32], key: u64) -> Option<Hit> {
        let mut best = tmax;
        let mut obj = None;
        let mut prim = 0;
        for &i in active {
            let o = &self.objects[i as usize];
            if o.aabb.hit(r, best).is_none() {
                continue;
            }
            for (j, p) in o.prims.iter().enumerate() {
                let k = key ^ splitmix(((i as u64) << 20) ^ j as u64);
                if let Some(t) = p.hit(r, k)
                    && t < best
                {
                    best = t;
                    obj = Some(i);
                    prim = j as u32;
                }
            }
        }
        if let Some(t) = self.ground.hit(r, best) {
            return Some(Hit {
                t,
                object: None,
                prim: 0,
            });
        }
        obj.map(|o| Hit {
            t: best,
            object: Some(o),
            prim,
        })
    }

    /// Objects whose box is within `range` of `p`.
    pub fn near(&self, p: &Vector3<f64>, range: f64) -> Vec<u32> {
        (0..self.objects.len() as u32)
            .filter(|&i| self.objects[i as usize].aabb.distance(p) <= range)
            .collect()
    }
}

#[cfg(test)]
mod tests;
