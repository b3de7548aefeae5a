//! A whole-map pass that summarises every point: pieces are decoded and folded
//! on all threads, each into its own accumulator, and the accumulators are
//! merged. Merges must be order-free (minima, counts), which keeps the result
//! independent of the thread count.

use super::{PointReader, Scratch};
use crate::{Point, Result};
use rayon::prelude::*;

/// Folds every finite point of `reader` into an `A`: `fold(acc, piece)` per
/// piece, `merge(into, from)` to combine. `progress` gets the bytes consumed.
pub(crate) fn fold_points<A: Send>(
    reader: &mut dyn PointReader,
    new: impl Fn() -> A + Sync,
    fold: impl Fn(&mut A, &[Point]) + Sync,
    merge: impl Fn(&mut A, A) + Sync,
    progress: impl FnMut(u64),
) -> Result<A> {
    fold_points_until(reader, new, fold, merge, |_| false, progress)
}

/// [`fold_points`] that stops reading once `enough(total)` holds after a
/// batch (a pass that has seen what makes its result an error).
pub(crate) fn fold_points_until<A: Send>(
    reader: &mut dyn PointReader,
    new: impl Fn() -> A + Sync,
    fold: impl Fn(&mut A, &[Point]) + Sync,
    merge: impl Fn(&mut A, A) + Sync,
    enough: impl Fn(&A) -> bool,
    mut progress: impl FnMut(u64),
) -> Result<A> {
    let mut total = new();
    let mut buf = Vec::new();
    loop {
        let Some(batch) = reader.next_batch(&mut buf)? else {
            break;
        };
        let n = batch.pieces();
        let part = (0..n)
            .into_par_iter()
            .fold(
                || (new(), Scratch::default(), Ok(())),
                |(mut acc, mut scratch, res): (A, Scratch, Result<()>), i| {
                    if res.is_err() {
                        return (acc, scratch, res);
                    }
                    let res = batch.piece(i, &mut scratch).map(|p| fold(&mut acc, p));
                    (acc, scratch, res)
                },
            )
            .map(|(acc, _, res)| res.map(|()| acc))
            .reduce(
                || Ok(new()),
                |a, b| {
                    let (mut a, b) = (a?, b?);
                    merge(&mut a, b);
                    Ok(a)
                },
            )?;
        drop(batch);
        merge(&mut total, part);
        progress(reader.bytes_read());
        if enough(&total) {
            break;
        }
    }
    Ok(total)
}
