//! The loose crops: where each target is expected in the map, and one
//! pass that reads the points around them.

use super::*;

/// Every position but the `i`-th.
pub(super) fn others_than(positions: &[Point], i: usize) -> Vec<Point> {
    let mut v = positions.to_vec();
    v.remove(i);
    v
}

/// Where every surveyed target is expected in the (levelled) map.
/// With `level` (a transform in the map's own frame), the positions are moved
/// by the levelling at the centre of rotation's height: the survey's heights
/// may sit metres above or below the map's, and the crop is a cylinder.
pub(super) fn expected_positions(
    survey: &Survey,
    init: &crate::frame::MapToSurvey,
    dz: f64,
    level: Option<&RigidMotion>,
) -> Vec<Point> {
    survey
        .targets
        .iter()
        .map(|t| {
            let mut e = init.to_map(&t.reference());
            e.z -= dz;
            if let Some(m) = level.filter(|m| !m.is_identity()) {
                let q = m.apply(&Point::new(e.x, e.y, m.origin.z));
                e.x = q.x;
                e.y = q.y;
                e.z += q.z - m.origin.z;
            }
            e
        })
        .collect()
}

/// Per centre, the crop's points and how many were offered before thinning.
pub(super) type Crops = Vec<(Vec<Point>, u64)>;

/// What [`read_crops`] read: per centre the crop, and whether it holds only
/// the coarse levels of a COPC octree (to be read in detail near what is
/// found there), with the pass's reads (the crops; a crop short of its
/// levels' estimate read again).
pub(super) struct CropsRead {
    pub(super) crops: Crops,
    pub(super) coarse: Vec<bool>,
    pub(super) read: crate::cloud::PassRead,
    pub(super) again: Option<crate::cloud::PassRead>,
}

/// The loose crops around `centres` in one pass over the map, each with the
/// number of points the map had there before thinning, and what the pass read;
/// with `params.by_level`, only the levels that hold `params.coarse_points`
/// near each centre.
pub(super) fn read_crops(
    source: MapSource,
    centres: &[Point],
    params: &LooseParams,
    motion: &RigidMotion,
    z_range: Option<[f64; 2]>,
    map: &mut MapStats,
    progress: &mut impl FnMut(u64, u64),
) -> Result<CropsRead> {
    // With the map's z range, a tilted map's region hint reaches its reader
    // (tiles and COPC nodes far from the targets stay unread).
    let mut reader = source.open_moved_within(Some(motion), z_range)?;
    let total = reader.info().file_bytes;
    if reader.tile_stats().is_none() {
        map.bytes = total;
    }
    let enough = params.coarse_points;
    let mut crop = if params.by_level {
        crop::loose_crop_by_level(reader.as_mut(), centres, params, enough, |b| {
            progress(b, total)
        })?
    } else {
        crop::loose_crop(reader.as_mut(), centres, params, |b| progress(b, total))?
    };
    // A tiled map's crop opened only the tiles near the targets: its counts
    // are not the map's (the ground pass's are kept).
    if reader.tile_stats().is_none_or(|t| t.selected == t.tiles) {
        map.points = crop.map_points;
        map.skipped_nonfinite = crop.skipped_nonfinite;
    }
    let read = crate::cloud::PassRead::of("crops", reader.as_ref());
    let mut coarse: Vec<bool> = (0..centres.len())
        .map(|i| crop.levels_cut.get(i).copied().unwrap_or(false))
        .collect();
    // A COPC octree read to the levels that hold enough points near a
    // target: a crop that came out with no more than that was short of the
    // estimate, and is read again at every level (its own entry in
    // `eval.reads`: the two reads share the coarse nodes).
    let short: Vec<usize> = (0..centres.len())
        .filter(|&i| coarse[i] && crop.offered[i] <= enough)
        .collect();
    let mut again_read = None;
    if !short.is_empty() {
        let at: Vec<Point> = short.iter().map(|&i| centres[i]).collect();
        let (full, again) = read_near(source, &at, params, motion, z_range, progress)?;
        again_read = Some(crate::cloud::PassRead {
            pass: "crops-again".into(),
            ..again
        });
        for (k, (pts, offered)) in full.into_iter().enumerate() {
            crop.points[short[k]] = pts;
            crop.offered[short[k]] = offered;
            coarse[short[k]] = false;
        }
    }
    Ok(CropsRead {
        crops: crop.points.into_iter().zip(crop.offered).collect(),
        coarse,
        read,
        again: again_read,
    })
}

/// Every level of the map within `params.radius` of each of `centres` (a
/// crop as `crop` reads it), and what the read cost (pass "crops").
pub(super) fn read_near(
    source: MapSource,
    centres: &[Point],
    params: &LooseParams,
    motion: &RigidMotion,
    z_range: Option<[f64; 2]>,
    progress: &mut impl FnMut(u64, u64),
) -> Result<(Crops, crate::cloud::PassRead)> {
    let mut reader = source.open_moved_within(Some(motion), z_range)?;
    let total = reader.info().file_bytes;
    let full = crop::loose_crop(reader.as_mut(), centres, params, |b| progress(b, total))?;
    let read = crate::cloud::PassRead::of("crops", reader.as_ref());
    Ok((full.points.into_iter().zip(full.offered).collect(), read))
}

/// The crops with intensities ([`crate::crop::crops_with_intensity`]: the
/// crop pass carries coordinates only, and a board is told by its print) of
/// the survey's board targets among `which` (indices
/// into the survey), searched about `centres` (one per `which`); no pass
/// when there are none or crops are hand-made (`auto` false).
#[allow(clippy::too_many_arguments)]
pub(super) fn board_crops_of(
    source: MapSource,
    survey: &Survey,
    centres: &[Point],
    which: &[usize],
    auto: bool,
    cfg: &Config,
    motion: &RigidMotion,
    z_range: Option<[f64; 2]>,
) -> Result<(Vec<Option<BoardCrop>>, Option<crate::cloud::PassRead>)> {
    let mut side: f64 = 0.0;
    let at: Vec<Option<Point>> = which
        .iter()
        .zip(centres)
        .map(|(&i, c)| {
            let t = &survey.targets[i];
            (auto && t.model == crate::model::ModelKind::Board).then(|| {
                side = side.max(t.size.unwrap_or(cfg.board.side_m));
                *c
            })
        })
        .collect();
    crate::crop::crops_with_intensity(
        source,
        &at,
        cfg.board.search_radius_m + side,
        cfg.board.max_points,
        motion,
        z_range,
    )
}

/// A board target's crop: its points and their intensities, or why the map
/// has none to give.
pub(crate) type BoardCrop = crate::crop::IntensityCrop;

#[cfg(test)]
mod tests {
    use super::*;

    /// A COPC crop read to the coarse levels that came out no larger than
    /// it needs (a sphere hanging over the cloud's slab: the nodes' squares
    /// promise a cylinder's points) is read again at every level, and comes
    /// out as a crop of every level does; the others stay coarse.
    #[test]
    fn a_copc_crop_short_of_its_levels_estimate_is_read_again_whole() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/random-20k.copc.laz");
        let source = MapSource::File(&path);
        let centres = [
            Point::new(350_100.5, 4_150_100.5, 10.0),
            Point::new(350_312.2, 4_150_250.7, 70.0),
        ];
        let params = crop::LooseParams {
            radius: 60.0,
            shape: crop::Shape::Sphere,
            max_points: 60,
            by_level: true,
            coarse_points: 60,
        };
        let flat = RigidMotion::identity_at(Point::origin());
        let mut map = MapStats::default();
        let CropsRead {
            crops,
            coarse: cut,
            read,
            again,
        } = read_crops(
            source,
            &centres,
            &params,
            &flat,
            None,
            &mut map,
            &mut |_, _| {},
        )
        .unwrap();
        let again = again.expect("the short crop read again");
        assert_eq!(cut, [true, false], "the one read again holds every level");
        let mut r = crate::cloud::open(&path).unwrap();
        let every = crop::loose_crop(r.as_mut(), &centres, &params, |_| {}).unwrap();
        let whole = crate::cloud::PassRead::of("crops", r.as_ref());
        // The sphere's cap: every level read for it, as a whole crop.
        assert!(every.offered[1] > 60 && crops[1].1 == every.offered[1]);
        assert_eq!(crops[1].0, every.points[1]);
        // The other crop: the coarse levels, more than it keeps.
        assert!(
            crops[0].1 > 60 && 3 * crops[0].1 < every.offered[0],
            "{crops:?}"
        );
        // Both reads counted, less than reading every level near both.
        let mut r = crate::cloud::open(&path).unwrap();
        let coarse = crop::loose_crop_by_level(r.as_mut(), &centres, &params, 60, |_| {}).unwrap();
        // Both discs share the root: one group, both cut.
        assert_eq!(coarse.levels_cut, [true, true]);
        assert!(coarse.offered[1] <= 60, "{:?}", coarse.offered);
        let first = crate::cloud::PassRead::of("crops", r.as_ref());
        assert_eq!(first, read);
        assert!(read.bytes < whole.bytes, "{read:?} against {whole:?}");
        // Only the sphere's crop was read again.
        assert!(
            again.pass == "crops-again" && again.bytes < whole.bytes,
            "{again:?}"
        );
    }
}
