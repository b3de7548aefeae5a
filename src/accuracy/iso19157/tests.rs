use super::*;

#[test]
fn without_bias_they_are_the_closed_forms() {
    // ISO 19157's CE90 = 2.1460 σ_c, CE95 = 2.4477 σ_c (√(−2 ln(1 − p)));
    // LE90 = 1.6449 σ, LE95 = 1.9600 σ.
    let s = 0.02;
    let ce90 = circular_error([0.0, 0.0], [s, s], 0.90);
    let ce95 = circular_error([0.0, 0.0], [s, s], 0.95);
    assert!((ce90 - 2.145_966 * s).abs() < 1e-6, "{ce90}");
    assert!((ce95 - 2.447_747 * s).abs() < 1e-6, "{ce95}");
    assert!((linear_error(0.0, s, 0.90) - 1.644_854 * s).abs() < 1e-6);
    assert!((linear_error(0.0, s, 0.95) - 1.959_964 * s).abs() < 1e-6);
}

#[test]
fn a_bias_widens_them_as_worked_apart() {
    // LE90 of N(1, 1): Φ(h − 1) − Φ(−h − 1) = 0.9 at h = 2.284468 (Python's
    // statistics.NormalDist, bisection).
    assert!((linear_error(1.0, 1.0, 0.90) - 2.284_468).abs() < 1e-5);
    // A bias of 3 σ on one axis: nearly all of the error lies in a disc about
    // the bias, so CE90 → bias + 1.2816 σ along it as the bias grows; at 3 σ
    // the other axis adds a little (between that and bias + CE90 alone).
    let ce = circular_error([0.03, 0.0], [0.01, 0.01], 0.90);
    assert!(ce > 0.03 + 0.012_816 && ce < 0.03 + 0.021_46, "{ce}");
    // A narrow axis beside a wide one (the reviewer's case: 256 steps along
    // the narrow axis missed its peak, 81.5 mm), the bias along either; 4 M
    // Monte Carlo draws (numpy) put CE90 at 26.41 and 21.67 mm, and at
    // 20.39 mm for a narrow error all of whose mass lies 20 mm out.
    for (b, s, want) in [
        ([0.0, 0.02], [0.0003, 0.005], 0.026_41),
        ([0.0, 0.02], [0.005, 0.0003], 0.021_67),
        ([0.02, 0.0], [0.0003, 0.0003], 0.020_39),
    ] {
        let got = circular_error(b, s, 0.90);
        assert!((got - want).abs() < 2e-5, "{b:?} {s:?}: {got}");
    }
    // Turning the axes turns nothing: a bias on y as on x.
    let ce_y = circular_error([0.0, 0.03], [0.01, 0.01], 0.90);
    assert!((ce - ce_y).abs() < 1e-9);
}

#[test]
fn bias_intervals_and_counts_above_a_threshold() {
    let res: Vec<Vector3<f64>> = [
        (0.010, 0.000, 0.02),
        (0.012, -0.004, -0.01),
        (0.008, 0.006, 0.00),
        (0.014, 0.002, 0.05),
        (0.006, -0.002, 0.01),
    ]
    .iter()
    .map(|&(x, y, z)| Vector3::new(x, y, z))
    .collect();
    let m = iso19157(&res, true, Some(0.012));
    assert_eq!(m.n, 5);
    // x: mean 0.010, s = 0.0031623, t(4) = 2.7764: ± 0.0039265.
    assert!((m.bias[0].mean - 0.010).abs() < 1e-12);
    let ci = m.bias[0].ci95.unwrap();
    // (mapgauge's t is tabled to 3 decimals: 2.776, within 1e-5 m here.)
    assert!((ci[1] - ci[0] - 2.0 * 2.776_445 * 0.003_162_278 / 5f64.sqrt()).abs() < 1e-5);
    // Horizontal errors 10.0, 12.6, 10.0, 14.1, 6.3 mm: 2 above 12 mm.
    assert_eq!((m.above_h, m.rate_above_h), (Some(2), Some(0.4)));
    // Vertical 20, 10, 0, 50, 10 mm: 2 above 12 mm.
    assert_eq!(m.above_v, Some(2));
    assert!(m.ce90.unwrap() > m.bias[0].mean && m.ce95.unwrap() > m.ce90.unwrap());
    assert!(m.le95.unwrap() > m.le90.unwrap());
    // Without heights or a threshold, those are absent; too few, no CE.
    let m = iso19157(&res[..2], false, None);
    assert_eq!(
        (m.bias.len(), m.ce90, m.le90, m.above_h),
        (2, None, None, None)
    );
}
