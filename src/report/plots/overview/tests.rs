use super::*;

#[test]
fn labels_keep_off_arrows_and_each_other() {
    let frame = (0.0, 0.0, 500.0, 500.0);
    let s = (200.0, 200.0);
    // Nothing in the way: upper right, as before.
    let (at, a, _) = place_label(s, "t1", &[], &[s], &[], frame);
    assert_eq!((at, a), ((208.0, 190.0), Anchor::Start));
    // An arrow up and to the right: the label goes elsewhere and covers none of it.
    let seg = (s, (240.0, 170.0));
    let (_, _, b) = place_label(s, "t1", &[seg], &[s], &[], frame);
    for i in 0..=20 {
        let t = i as f64 / 20.0;
        let p = (s.0 + t * 40.0, s.1 - t * 30.0);
        assert!(
            !(p.0 >= b.0 && p.0 <= b.2 && p.1 >= b.1 && p.1 <= b.3),
            "label box {b:?} covers the arrow at {p:?}"
        );
    }
    // A second label at the same place does not sit on the first.
    let (_, _, b1) = place_label(s, "t1", &[seg], &[s], &[], frame);
    let (_, _, b2) = place_label(s, "t2", &[seg], &[s], &[b1], frame);
    assert!(!(b1.0 < b2.2 && b2.0 < b1.2 && b1.1 < b2.3 && b2.1 < b1.3));
}
