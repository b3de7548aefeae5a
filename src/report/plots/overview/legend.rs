//! The overview's legend column: what its marks are, the scale of the
//! magnified errors, the backdrop drawn under them, and the run in numbers.

use super::footprint::FOOTPRINT_SHADES;
use crate::record::ResultFile;
use crate::report::figure::{Anchor, Figure, Item, MarkerKind, nice_step, palette};
use crate::report::plots::{legend_line, legend_marker};

/// Legend column's left edge.
const LX: f64 = 592.0;

/// What the legend says beyond its fixed entries.
pub(super) struct Legend {
    /// The errors' magnification.
    pub(super) k: f64,
    /// The largest error (m; 0 when none).
    pub(super) max_err: f64,
    /// The panel's pixels per metre.
    pub(super) scale: f64,
    /// Whether the route was drawn.
    pub(super) drawn_route: bool,
    /// Whether the map's footprint was drawn.
    pub(super) shaded: bool,
}

/// The legend, top to bottom except that the backdrop's entries sit below
/// the run's numbers.
pub(super) fn legend(f: &mut Figure, r: &ResultFile, key: &Legend) {
    marks(f);
    scale_bar(f, key);
    backdrop(f, key);
    run_facts(f, r);
}

/// The three marks: a surveyed position, an error arrow, a target not found.
fn marks(f: &mut Figure) {
    f.bold((LX, 50.0), "Legend", 12.0, Anchor::Start);
    legend_marker(
        f,
        (LX + 6.0, 74.0),
        MarkerKind::Ring,
        palette::SURVEY,
        "surveyed position",
    );
    f.items.push(Item::Arrow {
        a: (LX, 98.0),
        b: (LX + 24.0, 98.0),
        color: palette::PLATE1,
        width: 2.0,
    });
    f.text(
        (LX + 30.0, 98.0),
        "aligned estimate",
        11.0,
        palette::INK,
        Anchor::Start,
    );
    f.text(
        (LX + 30.0, 112.0),
        "− survey (error)",
        11.0,
        palette::INK,
        Anchor::Start,
    );
    legend_marker(
        f,
        (LX + 6.0, 136.0),
        MarkerKind::Cross,
        palette::ERROR,
        "not found",
    );
}

/// The magnification, and an arrow of a round error at that magnification
/// (clipped to the column) with the largest error: arrows magnified this
/// much are read against it, not against the axes.
fn scale_bar(f: &mut Figure, key: &Legend) {
    let (k, max_err) = (key.k, key.max_err);
    f.bold(
        (LX, 170.0),
        &format!("errors magnified ×{}", fmt_k(k)),
        12.0,
        Anchor::Start,
    );
    if max_err > 0.0 {
        let unit = nice_step(max_err / 2.0);
        let len = unit * k * key.scale;
        f.items.push(Item::Arrow {
            a: (LX, 192.0),
            b: (LX + len.min(170.0), 192.0),
            color: palette::PLATE1,
            width: 2.0,
        });
        f.text(
            (LX, 208.0),
            &format!(
                "= {} error{}",
                fmt_len(unit),
                if len > 170.0 { " (clipped)" } else { "" }
            ),
            11.0,
            palette::INK,
            Anchor::Start,
        );
        f.text(
            (LX, 230.0),
            &format!("largest: {}", fmt_len(max_err)),
            11.0,
            palette::INK,
            Anchor::Start,
        );
    }
}

/// The entries of what was drawn under the targets, when it was: the route
/// and the map's footprint.
fn backdrop(f: &mut Figure, key: &Legend) {
    if key.drawn_route {
        legend_line(
            f,
            (LX, 330.0),
            palette::SAMPLE,
            1.5,
            false,
            "the trajectory",
        );
    }
    if key.shaded {
        f.items.push(Item::Rect {
            at: (LX, 288.0),
            size: (18.0, 12.0),
            fill: Some(FOOTPRINT_SHADES[2]),
            stroke: None,
        });
        f.text(
            (LX + 24.0, 294.0),
            "the map from above",
            11.0,
            palette::INK,
            Anchor::Start,
        );
        f.text(
            (LX + 24.0, 308.0),
            "(darker: more covered)",
            11.0,
            palette::INK,
            Anchor::Start,
        );
    }
}

/// How many targets were found, and the alignment that placed them.
fn run_facts(f: &mut Figure, r: &ResultFile) {
    let (n_found, excluded) = r.found();
    let apart = if excluded > 0 {
        format!(" ({excluded} excluded)")
    } else {
        String::new()
    };
    f.text(
        (LX, 252.0),
        &format!("{n_found} of {} targets found{apart}", r.targets.len()),
        11.0,
        palette::INK,
        Anchor::Start,
    );
    f.text(
        (LX, 274.0),
        &format!("alignment: {}", r.alignment.method),
        11.0,
        palette::INK,
        Anchor::Start,
    );
}

fn fmt_k(k: f64) -> String {
    if k >= 1.0 {
        format!("{k:.0}")
    } else {
        format!("{k}")
    }
}

/// A length in mm below 1 m, in m above.
pub(crate) fn fmt_len(m: f64) -> String {
    if m.abs() < 1.0 {
        format!("{:.1} mm", m * 1000.0)
    } else {
        format!("{m:.3} m")
    }
}
