//! A COPC file's octree and its region hints: which nodes lie near the
//! targets' discs, and how many levels of them a read that keeps enough
//! points near each disc needs.
//!
//! Why its own file: choosing nodes is geometry over the octree's keys and
//! cubes, apart from decoding the chosen chunks (`chunked.rs`).

use super::super::TileStats;
use super::Chunk;

/// A COPC file's octree: the voxel key and cube of each chunk (node).
pub(super) struct Octree {
    /// Level, x, y, z of each node's voxel key.
    pub(super) keys: Vec<[i32; 4]>,
    /// Each node's cube: min x, min y, min z, max x, max y, max z.
    pub(super) cubes: Vec<[f64; 6]>,
    /// How far outside its cube a point may lie (coordinate rounding).
    pub(super) slack: f64,
    pub(super) counts: TileStats,
    /// The discs of a region hint, kept for [`PointReader::hint_enough`](super::super::PointReader::hint_enough).
    pub(super) discs: Option<(Vec<[f64; 2]>, f64)>,
    /// Per disc, whether a [`PointReader::hint_enough`](super::super::PointReader::hint_enough) left nodes of deep
    /// levels near it unread (empty: none was).
    pub(super) levels_cut: Vec<bool>,
}

/// Points of a level-limited read near a disc, as a multiple of what the
/// consumer keeps: the estimate (each node's points placed as its subtree's
/// are, [`Octree::subtree_shares`]) is rough, and reading a little more than needed costs little,
/// while a short read costs that disc's whole read again.
const LEVEL_MARGIN: f64 = 1.5;

/// Levels below a node whose points tell where its own lie: a writer's
/// coarse levels keep one point per voxel of their grid, spread more evenly
/// than the deepest levels' raw density, so only the next levels down speak
/// for a node (a dense strip would otherwise draw its estimate too high and
/// the read stop a level short, to be read again whole).
const SUBTREE_LEVELS: i32 = 2;

/// Cells per side of the grid that estimates the share of a node's square
/// inside a disc (within about 1/16 of the disc's bounding box).
const SHARE_CELLS: usize = 16;

/// The share of the square `[x0, x1] × [y0, y1]` within `r` of `c`,
/// counted on a grid over the part of the square in the disc's bounding box.
fn share_in_disc(sq: [f64; 4], c: [f64; 2], r: f64) -> f64 {
    let [x0, y0, x1, y1] = sq;
    let (ax, bx) = (x0.max(c[0] - r), x1.min(c[0] + r));
    let (ay, by) = (y0.max(c[1] - r), y1.min(c[1] + r));
    let area = (x1 - x0) * (y1 - y0);
    if !(bx > ax && by > ay && area > 0.0) {
        return 0.0;
    }
    let (dx, dy) = (
        (bx - ax) / SHARE_CELLS as f64,
        (by - ay) / SHARE_CELLS as f64,
    );
    let mut inside = 0usize;
    for j in 0..SHARE_CELLS {
        let y = ay + (j as f64 + 0.5) * dy - c[1];
        for i in 0..SHARE_CELLS {
            let x = ax + (i as f64 + 0.5) * dx - c[0];
            inside += usize::from(x * x + y * y <= r * r);
        }
    }
    (inside as f64 * dx * dy / area).min(1.0)
}

impl Octree {
    /// Per disc, the share of each node's points inside it (nodes near no
    /// disc left out), estimated from the node's subtree: a coarse node's
    /// points are a sample of the map below it, and its descendants' counts
    /// tell where in its cube those lie. Spread evenly over a coarse node's
    /// square, the points of a road corridor 20 m wide in a node 40 m wide
    /// were half as many in a disc on the road as they are, and the read
    /// went a level deeper than it needed (a level holds ~8× the one above).
    /// Each node weighs its own square's share by its points; a node's
    /// estimate is the weighted mean over itself and its descendants down
    /// to `SUBTREE_LEVELS` below it.
    fn subtree_shares(
        &self,
        chunks: &[Chunk],
        discs: &[[f64; 2]],
        radius: f64,
    ) -> Vec<std::collections::HashMap<usize, f64>> {
        let index: std::collections::HashMap<[i32; 4], usize> =
            self.keys.iter().enumerate().map(|(i, k)| (*k, i)).collect();
        let n = self.keys.len();
        // Every node's points count below each of its ancestors (the
        // denominator holds the nodes far from every disc too).
        let mut total = vec![0.0f64; n];
        let mut inside: Vec<std::collections::HashMap<usize, f64>> =
            vec![std::collections::HashMap::new(); discs.len()];
        for i in 0..n {
            let w = chunks[i].points as f64;
            let c = &self.cubes[i];
            let own: Vec<(usize, f64)> = (0..discs.len())
                .filter(|&k| self.near(c, &discs[k], radius))
                .map(|k| (k, share_in_disc([c[0], c[1], c[3], c[4]], discs[k], radius)))
                .filter(|s| s.1 > 0.0)
                .collect();
            // Up to `SUBTREE_LEVELS` ancestors, through any the hierarchy
            // leaves out (a writer may omit an empty node).
            let mut key = self.keys[i];
            for up in 0..=SUBTREE_LEVELS {
                if let Some(&a) = index.get(&key) {
                    total[a] += w;
                    for &(k, share) in &own {
                        *inside[k].entry(a).or_insert(0.0) += w * share;
                    }
                }
                if key[0] == 0 || up == SUBTREE_LEVELS {
                    break;
                }
                key = [key[0] - 1, key[1] >> 1, key[2] >> 1, key[3] >> 1];
            }
        }
        for m in &mut inside {
            for (a, v) in m.iter_mut() {
                *v = if total[*a] > 0.0 {
                    (*v / total[*a]).min(1.0)
                } else {
                    0.0
                };
            }
        }
        inside
    }

    /// Whether cube `c` comes within `radius` of `p` horizontally.
    pub(super) fn near(&self, c: &[f64; 6], p: &[f64; 2], radius: f64) -> bool {
        let s = self.slack;
        let dx = (c[0] - s - p[0]).max(p[0] - c[3] - s).max(0.0);
        let dy = (c[1] - s - p[1]).max(p[1] - c[4] - s).max(0.0);
        dx * dx + dy * dy <= radius * radius
    }

    /// Of the nodes `order` (those near some disc), the ones a read that
    /// keeps `enough` points per disc needs, and per disc whether any near it
    /// is left out: near each disc, the levels from the root down to the
    /// first whose nodes hold, with those above it, `LEVEL_MARGIN` times
    /// `enough` points there by estimate (every level when none does), and
    /// every level a neighbouring disc reads in a node near both.
    pub(super) fn enough_levels(
        &self,
        order: &[usize],
        chunks: &[Chunk],
        enough: u64,
    ) -> (Vec<usize>, Vec<bool>) {
        let Some((discs, radius)) = &self.discs else {
            return (order.to_vec(), Vec::new());
        };
        let want = LEVEL_MARGIN * enough as f64;
        // Per node of `order`, the discs it is near (once: the estimate and
        // the neighbours' levels both ask).
        let near: Vec<Vec<usize>> = order
            .iter()
            .map(|&i| {
                (0..discs.len())
                    .filter(|&k| self.near(&self.cubes[i], &discs[k], *radius))
                    .collect()
            })
            .collect();
        // Per disc, (level, estimated points inside it) of each node near it.
        let shares = self.subtree_shares(chunks, discs, *radius);
        let mut by_level: Vec<Vec<(i32, f64)>> = vec![Vec::new(); discs.len()];
        for (&i, ks) in order.iter().zip(&near) {
            for &k in ks {
                let share = shares[k].get(&i).copied().unwrap_or(0.0);
                by_level[k].push((self.keys[i][0], share * chunks[i].points as f64));
            }
        }
        let deepest: Vec<i32> = by_level
            .into_iter()
            .map(|mut by_level| {
                by_level.sort_unstable_by_key(|l| l.0);
                let mut sum = 0.0;
                for (k, &(level, n)) in by_level.iter().enumerate() {
                    sum += n;
                    let last_of_level = by_level.get(k + 1).is_none_or(|l| l.0 != level);
                    if last_of_level && sum >= want {
                        return level;
                    }
                }
                i32::MAX
            })
            .collect();
        // A node read for one disc is read for every disc it is near (a crop
        // takes every point within its radius): such a disc reads that level
        // everywhere near it, or the part it shares with its neighbour would
        // be denser than the rest. Raised until nothing changes (each raise
        // only adds nodes; levels are bounded).
        let mut depth = deepest;
        loop {
            let mut raised = false;
            for (&i, ks) in order.iter().zip(&near) {
                let level = self.keys[i][0];
                if ks.iter().any(|&k| level <= depth[k]) {
                    for &k in ks {
                        if level > depth[k] {
                            depth[k] = level;
                            raised = true;
                        }
                    }
                }
            }
            if !raised {
                break;
            }
        }
        let mut cut = vec![false; discs.len()];
        let mut keep = Vec::with_capacity(order.len());
        for (&i, ks) in order.iter().zip(&near) {
            let level = self.keys[i][0];
            if ks.iter().any(|&k| level <= depth[k]) {
                keep.push(i);
            } else {
                for &k in ks {
                    cut[k] = true;
                }
            }
        }
        (keep, cut)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A root 40 m wide whose points all lie below one 20 m quarter (its one
    /// child): in a disc on that quarter, the root's points are estimated
    /// from where the child's are, not spread over the root's whole square.
    #[test]
    fn a_coarse_nodes_share_follows_its_subtree() {
        let chunk = |points| Chunk {
            offset: 0,
            bytes: 0,
            points,
        };
        let tree = Octree {
            keys: vec![[0, 0, 0, 0], [1, 0, 0, 0]],
            cubes: vec![
                [0.0, 0.0, 0.0, 40.0, 40.0, 40.0],
                [0.0, 0.0, 0.0, 20.0, 20.0, 20.0],
            ],
            slack: 0.0,
            counts: TileStats::default(),
            discs: None,
            levels_cut: Vec::new(),
        };
        let chunks = [chunk(1_000), chunk(8_000)];
        let disc = [[10.0, 10.0]];
        let s = tree.subtree_shares(&chunks, &disc, 5.0);
        let even_root = share_in_disc([0.0, 0.0, 40.0, 40.0], disc[0], 5.0);
        let child = share_in_disc([0.0, 0.0, 20.0, 20.0], disc[0], 5.0);
        assert!((child - 0.196).abs() < 0.01, "{child}");
        assert!((s[0][&1] - child).abs() < 1e-12);
        // The root: its own even share and its child's, weighed by points.
        let want = (1_000.0 * even_root + 8_000.0 * child) / 9_000.0;
        assert!((s[0][&0] - want).abs() < 1e-12 && s[0][&0] > 3.0 * even_root);
        // A disc over the empty quarters: only the root's own points count.
        let far = tree.subtree_shares(&chunks, &[[30.0, 30.0]], 5.0);
        let own = share_in_disc([0.0, 0.0, 40.0, 40.0], [30.0, 30.0], 5.0);
        assert!((far[0][&0] - 1_000.0 * own / 9_000.0).abs() < 1e-12);
        assert!(!far[0].contains_key(&1));
        // A node whose parent the hierarchy leaves out still speaks for its
        // grandparent, and nodes more than `SUBTREE_LEVELS` below do not.
        let tree = Octree {
            keys: vec![[0, 0, 0, 0], [2, 0, 0, 0], [3, 0, 0, 0]],
            cubes: vec![
                [0.0, 0.0, 0.0, 40.0, 40.0, 40.0],
                [0.0, 0.0, 0.0, 10.0, 10.0, 10.0],
                [0.0, 0.0, 0.0, 5.0, 5.0, 5.0],
            ],
            ..tree
        };
        let chunks = [chunk(1_000), chunk(4_000), chunk(32_000)];
        let disc = [[5.0, 5.0]];
        let s = tree.subtree_shares(&chunks, &disc, 5.0);
        let sq = |w: f64| share_in_disc([0.0, 0.0, w, w], disc[0], 5.0);
        let want = (1_000.0 * sq(40.0) + 4_000.0 * sq(10.0)) / 5_000.0;
        assert!(
            (s[0][&0] - want).abs() < 1e-12,
            "{} against {want}",
            s[0][&0]
        );
        let want = (4_000.0 * sq(10.0) + 32_000.0 * sq(5.0)) / 36_000.0;
        assert!((s[0][&1] - want).abs() < 1e-12);
    }
}
