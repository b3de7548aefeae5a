//! Benchmark scores as the summary says them and as a table across runs.

use super::tables::{merged_ids, target_label};
use super::{Grid, fixed};
use crate::record::ResultFile;
use crate::scores::{BenchScore, ScoreKind, score};

/// One line per score in the result: `Hilti 2023 score 38.8 of 100 (95 %:
/// 35.0–41.7 as the errors' noise allows) · 4 of 6 targets located`.
pub fn score_lines(r: &ResultFile) -> Vec<String> {
    r.scores
        .iter()
        .map(|(k, s)| format!("{} score {}", k.title(), score_phrase(s)))
        .collect()
}

/// `38.8 of 100 (…) · 4 of 6 targets located`.
fn score_phrase(s: &BenchScore) -> String {
    let range = if s.range95[0] == s.range95[1] {
        String::new()
    } else {
        format!(
            " (95 %: {}–{} within the errors' noise)",
            fixed(s.range95[0], 1),
            fixed(s.range95[1], 1)
        )
    };
    format!(
        "{} of 100{range} · {} of {} targets located",
        fixed(s.total, 1),
        s.located,
        s.targets
    )
}

/// The scores of `runs` under `kinds`, one row per run: each rule's total,
/// then each target's points under the first rule. Computed from each
/// run's targets (the same rule as `eval --score`), so results written
/// without scores are scored too.
pub fn scores_grid(runs: &[(String, &ResultFile)], kinds: &[ScoreKind]) -> Grid {
    let ids = merged_ids(runs);
    let mut header = vec!["Run".to_string()];
    header.extend(kinds.iter().map(|k| k.title().to_string()));
    if let Some(first) = kinds.first() {
        header.extend(
            ids.iter()
                .map(|i| format!("{} {}", target_label(i), first.name())),
        );
    }
    let (rows, values) = runs
        .iter()
        .map(|(name, r)| {
            let s: Vec<BenchScore> = kinds.iter().map(|&k| score(k, r)).collect();
            let mut row = vec![name.clone()];
            let mut vals = vec![None];
            for b in &s {
                row.push(fixed(b.total, 1));
                vals.push(Some(b.total));
            }
            if let Some(first) = s.first() {
                for id in &ids {
                    let p = first.per_target.iter().find(|t| &t.id == id);
                    row.push(p.map(|p| fixed(p.points, 1)).unwrap_or_default());
                    vals.push(p.map(|p| p.points));
                }
            }
            (row, vals)
        })
        .unzip();
    Grid {
        header,
        rows,
        bold: (1..=kinds.len()).collect(),
        values,
    }
}

/// The rules any of `runs` was scored by, in the rules' order: what a table
/// of them shows when not told.
pub fn stored_scores(runs: &[(String, &ResultFile)]) -> Vec<ScoreKind> {
    ScoreKind::ALL
        .into_iter()
        .filter(|k| runs.iter().any(|(_, r)| r.scores.contains_key(k)))
        .collect()
}
