//! The absolute error without a fit, for a map already in the survey's
//! frame (georeferenced): the paper fits a transform before measuring,
//! which takes a map's global error out of its numbers; this is the error
//! the map carries as it is, and how much of it the fit took away.

use super::{Accuracy, Summary, dist, summarize};

/// The error of the map as it is against the survey.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unfitted {
    /// Statistics of |map − survey| over the scored targets, in the run's
    /// dimension (m).
    pub summary: Summary,
    /// The share of the unfitted mean error the fit removed:
    /// (unfitted − fitted) / unfitted; negative when the fit made it worse.
    pub absorbed: f64,
}

/// The unfitted errors of the targets `acc` scored; `None` without any.
/// Only meaningful when the map positions are in the survey's frame.
pub fn unfitted(acc: &Accuracy) -> Option<Unfitted> {
    let errors: Vec<f64> = acc
        .targets
        .iter()
        .filter(|t| t.abs_error.is_some())
        .filter_map(|t| t.map.map(|m| dist(&m, &t.survey, acc.dim)))
        .collect();
    if errors.is_empty() {
        return None;
    }
    let summary = summarize(&errors);
    let absorbed = if summary.mean > 0.0 {
        (summary.mean - acc.absolute.mean) / summary.mean
    } else {
        0.0
    };
    Some(Unfitted { summary, absorbed })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Point;
    use crate::accuracy::{ScoreOptions, score};
    use crate::survey::{Estimate, Survey};

    #[test]
    fn a_shifted_map_carries_its_shift_and_the_fit_takes_it() {
        let truth = [(0.0, 0.0), (30.0, 0.0), (30.0, 40.0), (0.0, 40.0)];
        let survey = Survey::local(&truth.map(|(x, y)| (x, y, 0.0)), false);
        // Shifted 0.3 m east and 0.4 m north (0.5 m), one target 1 cm off.
        let est: Vec<Estimate> = truth
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| {
                let off = if i == 2 { 0.01 } else { 0.0 };
                Estimate::found(
                    format!("t{}", i + 1),
                    Point::new(x + 0.3 + off, y + 0.4, 0.0),
                )
            })
            .collect();
        let acc = score(&survey, &est, &ScoreOptions::default()).expect("score");
        let u = unfitted(&acc).expect("unfitted");
        // Hand-worked: three targets 0.5 m off, one √(0.31² + 0.4²).
        let odd = (0.31f64 * 0.31 + 0.16).sqrt();
        assert!((u.summary.mean - (1.5 + odd) / 4.0).abs() < 1e-12);
        assert!((u.summary.max - odd).abs() < 1e-12);
        assert!(u.absorbed > 0.98 && u.absorbed < 1.0, "{}", u.absorbed);
    }
}
