use super::*;

fn plate() -> Plate {
    Plate {
        x: 0.0,
        y: 0.0,
        u: (1.0, 0.0),
        z0: 1.0,
        w: 0.6,
        h: 0.6,
        frame: 0.02,
        pitch: 0.04,
        hole: 0.028,
        keep: 1.0,
    }
}

#[test]
fn ray_through_plate_hole_passes_and_bar_is_hit() {
    let p = Prim::Plate(plate());
    // Plate lies in the plane y = 0; shoot along +y from y = -5.
    // Hole centre: s = frame + 5 * pitch + hole / 2, v likewise.
    let c = 0.02 + 5.0 * 0.04 + 0.014;
    let ray = Ray::new(Vector3::new(c, -5.0, 1.0 + c), Vector3::new(0.0, 1.0, 0.0));
    assert_eq!(p.hit(&ray, 0), None);
    // A bar between two holes.
    let b = 0.02 + 5.0 * 0.04 + 0.034;
    let ray = Ray::new(Vector3::new(b, -5.0, 1.0 + c), Vector3::new(0.0, 1.0, 0.0));
    let t = p.hit(&ray, 0).expect("bar must be hit");
    assert!((t - 5.0).abs() < 1e-12);
    // The frame is solid.
    let ray = Ray::new(Vector3::new(0.01, -5.0, 1.3), Vector3::new(0.0, 1.0, 0.0));
    assert!(p.hit(&ray, 0).is_some());
    // Beside the plate: nothing.
    let ray = Ray::new(Vector3::new(0.7, -5.0, 1.3), Vector3::new(0.0, 1.0, 0.0));
    assert_eq!(p.hit(&ray, 0), None);
}

#[test]
fn plate_open_fraction_is_about_half() {
    let p = plate();
    let n = 600;
    let mut solid = 0;
    for i in 0..n {
        for j in 0..n {
            let s = (i as f64 + 0.5) / n as f64 * p.w;
            let v = (j as f64 + 0.5) / n as f64 * p.h;
            solid += p.solid_at(s, v) as usize;
        }
    }
    let f = solid as f64 / (n * n) as f64;
    assert!((0.4..0.65).contains(&f), "solid fraction {f}");
}

#[test]
fn analytic_primitives() {
    let ray = Ray::new(Vector3::new(-10.0, 0.0, 1.0), Vector3::new(1.0, 0.0, 0.0));
    let b = Prim::Box {
        c: Vector3::new(0.0, 0.0, 1.0),
        half: Vector3::new(1.0, 1.0, 1.0),
        cs: (
            std::f64::consts::FRAC_1_SQRT_2,
            std::f64::consts::FRAC_1_SQRT_2,
        ),
    };
    // A 45°-rotated unit box presents its edge at x = -sqrt(2).
    assert!((b.hit(&ray, 0).unwrap() - (10.0 - 2f64.sqrt())).abs() < 1e-9);
    let c = Prim::VCyl {
        x: 0.0,
        y: 0.0,
        r: 0.5,
        z0: 0.0,
        z1: 2.0,
    };
    assert!((c.hit(&ray, 0).unwrap() - 9.5).abs() < 1e-9);
    let s = Prim::Sphere {
        c: Vector3::new(0.0, 0.0, 1.0),
        r: 2.0,
        porosity: 0.0,
    };
    assert!((s.hit(&ray, 0).unwrap() - 8.0).abs() < 1e-9);
    let above = Ray::new(Vector3::new(-10.0, 0.0, 5.0), Vector3::new(1.0, 0.0, 0.0));
    assert_eq!(c.hit(&above, 0), None);
    assert_eq!(b.hit(&above, 0), None);
    // Cylinder cap from above.
    let down = Ray::new(Vector3::new(0.1, 0.0, 5.0), Vector3::new(0.0, 0.0, -1.0));
    assert!((c.hit(&down, 0).unwrap() - 3.0).abs() < 1e-9);
    for p in [&b, &c, &s] {
        assert!(p.aabb().hit(&ray, 100.0).is_some());
    }
}

#[test]
fn ground_hit_lies_on_the_surface() {
    let g = Ground {
        z0: 0.0,
        cx: 0.0,
        cy: 0.0,
        gx: 0.03,
        gy: -0.01,
        waves: vec![
            Wave {
                kx: 0.6,
                ky: 0.2,
                amp: 0.08,
                phase: 0.3,
            },
            Wave {
                kx: -0.1,
                ky: 0.9,
                amp: 0.05,
                phase: 1.0,
            },
        ],
    };
    let mut many = g.clone();
    many.waves = (0..9)
        .map(|i| Wave {
            kx: 0.3 + 0.05 * i as f64,
            ky: -0.2,
            amp: 0.01,
            phase: i as f64,
        })
        .collect();
    for g in [&g, &many] {
        ground_hits_on_surface(g);
    }
    let up = Ray::new(Vector3::new(0.0, 0.0, 1.8), Vector3::new(0.0, 0.6, 0.8));
    assert_eq!(g.hit(&up, 150.0), None);
}

fn ground_hits_on_surface(g: &Ground) {
    for k in 0..200 {
        let az = k as f64 * 0.1;
        let el = -0.02 - 0.4 * (k as f64 / 200.0);
        let d = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let r = Ray::new(Vector3::new(3.0, -2.0, 1.8), d);
        if let Some(t) = g.hit(&r, 150.0) {
            let p = r.at(t);
            let f = p.z - g.height(p.x, p.y);
            assert!((-1e-9..6e-4).contains(&f), "off surface by {f}");
            // No earlier crossing: sample the ray densely before t.
            for i in 1..200 {
                let q = r.at(t * i as f64 / 200.0);
                assert!(q.z > g.height(q.x, q.y) - 1e-9);
            }
        }
    }
}
