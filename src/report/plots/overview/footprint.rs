//! The map under the overview: its footprint from above, as squares shaded
//! by how much of each holds points.

use crate::Point;
use crate::align::Alignment;
use crate::frame::Footprint;
use crate::report::figure::{Color, Item, Panel};

/// Shades of the map's footprint, from a few points in a pixel's square to
/// every part of it holding some.
pub(super) const FOOTPRINT_SHADES: [Color; 4] = [
    Color(0xee, 0xf0, 0xf3),
    Color(0xdd, 0xe1, 0xe7),
    Color(0xcb, 0xd1, 0xd9),
    Color(0xb6, 0xbe, 0xc9),
];

/// The footprint as shaded squares of at least 3 px in the panel (survey
/// frame less `off`), each row's runs of one shade merged into one
/// rectangle: a few thousand items however big the map.
pub(super) fn footprint_tiles(
    fp: &Footprint,
    al: &Alignment,
    panel: &Panel,
    off: (f64, f64),
) -> Vec<Item> {
    let scale = panel.scale();
    if fp.cells.is_empty() || !(scale > 0.0) || !(fp.cell > 0.0) {
        return Vec::new();
    }
    let (l, t, w, h) = panel.px;
    // A whole number of cells a square (an unturned map's cells then fall
    // in one square each), and each cell's area spread over it by 3 × 3
    // samples: a turned map's cells straddle squares, and a cell counted
    // whole in the square of its centre leaves a moiré of holes.
    let cell_px = fp.cell * scale;
    let pc = cell_px * (3.0 / cell_px).ceil().max(1.0);
    let (nx, ny) = ((w / pc).ceil() as usize, (h / pc).ceil() as usize);
    let mut area = vec![0.0f64; nx * ny];
    const SUB: usize = 3;
    for (c, share) in &fp.cells {
        let a = *share as f64 * fp.cell * fp.cell / (SUB * SUB) as f64;
        for si in 0..SUB {
            for sj in 0..SUB {
                let d = |s: usize| ((s as f64 + 0.5) / SUB as f64 - 0.5) * fp.cell;
                let q = al.apply(&Point::new(c[0] + d(si), c[1] + d(sj), c[2]));
                let (px, py) = panel.map(q.x - off.0, q.y - off.1);
                let (i, j) = (((px - l) / pc).floor(), ((py - t) / pc).floor());
                if i >= 0.0 && j >= 0.0 && (i as usize) < nx && (j as usize) < ny {
                    area[j as usize * nx + i as usize] += a;
                }
            }
        }
    }
    let bin = (pc / scale).powi(2);
    let shade = |a: f64| -> Option<usize> {
        (a > 0.0).then(|| (((a / bin).min(1.0) * 4.0).ceil() as usize).clamp(1, 4) - 1)
    };
    let mut items = Vec::new();
    for j in 0..ny {
        let mut i = 0;
        while i < nx {
            let Some(s) = shade(area[j * nx + i]) else {
                i += 1;
                continue;
            };
            let start = i;
            while i < nx && shade(area[j * nx + i]) == Some(s) {
                i += 1;
            }
            let (x0, y0) = (l + start as f64 * pc, t + j as f64 * pc);
            items.push(Item::Rect {
                at: (x0, y0),
                size: (
                    ((i - start) as f64 * pc).min(l + w - x0),
                    pc.min(t + h - y0),
                ),
                fill: Some(FOOTPRINT_SHADES[s]),
                stroke: None,
            });
        }
    }
    items
}
