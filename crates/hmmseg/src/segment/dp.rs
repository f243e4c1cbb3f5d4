//! A globally optimal segmentation over the stage-1 section boundaries (beyond the paper).
//!
//! Every partition of the sections covers the same samples, so the summed log-likelihood of all
//! segments is comparable between partitions. Segmental dynamic programming maximises
//!
//! `sum over segments (c^{r,s} - penalty)`
//!
//! subject to the TCP rise decision and (in [`GrammarMode::Enforce`]) the grammar. The state is
//! (sections consumed, last skill); only the runs of the score table's band are candidates:
//! `O(N S^2)` for `N` runs (`O(K^2 S^2)` without a length bound). The per-segment `penalty` (nats) counters the
//! tendency of more, shorter segments to fit better.

use super::{Context, Grammar, GrammarMode, ScoreTable, Segmentation};
use crate::error::{EngineError, Result};

/// Run the segmental DP; see the module docs. Filters that leave no complete path are relaxed
/// (rise decision first, then the grammar) with a warning.
pub fn dp<V: AsRef<[f64]>>(
    table: &ScoreTable<V>,
    grammar: &Grammar,
    rising: Option<&[bool]>,
    mode: GrammarMode,
    penalty: f64,
) -> Result<Segmentation> {
    if !penalty.is_finite() {
        return Err(EngineError::InvalidParameter(format!(
            "penalty must be finite, got {penalty}"
        )));
    }
    let ctx = Context::new(table, grammar, rising)?;
    let mut out = Segmentation::default();
    for (tier, &(use_rise, use_grammar)) in tiers(mode).iter().enumerate() {
        if let Some(path) = solve(&ctx, use_rise, use_grammar, penalty) {
            if tier > 0 {
                out.warnings.push(relaxed_warning(use_rise, use_grammar));
            }
            out.segments = path
                .into_iter()
                .map(|(s, i, j)| ctx.segment(s, i, j))
                .collect();
            if mode == GrammarMode::Warn {
                out.warnings.extend(ctx.grammar_warnings(&out.segments));
            }
            return Ok(out);
        }
    }
    // no finite score anywhere: one segment per section, first skill
    out.warnings
        .push("no finite score for any run of sections; output is a placeholder".into());
    out.segments = (0..table.n_sections())
        .map(|i| ctx.segment(0, i, i + 1))
        .collect();
    Ok(out)
}

/// The constraints `(rise decision, grammar)` tried in turn: filters that leave no complete
/// path are relaxed, the rise decision first, then the grammar.
pub(crate) fn tiers(mode: GrammarMode) -> &'static [(bool, bool)] {
    if mode == GrammarMode::Enforce {
        &[(true, true), (false, true), (true, false), (false, false)]
    } else {
        &[(true, false), (false, false)]
    }
}

/// The warning of a relaxed tier.
pub(crate) fn relaxed_warning(use_rise: bool, use_grammar: bool) -> String {
    format!(
        "no complete segmentation satisfies the {}; relaxed it",
        match (use_rise, use_grammar) {
            (false, true) => "TCP rise decision",
            (true, false) => "grammar",
            _ => "TCP rise decision and the grammar",
        }
    )
}

/// One cell of the DP: the best score of the sections up to some `j` ending with skill `s`, and
/// its back pointer `(start section, previous skill)` (`(0, usize::MAX)` for a first segment,
/// `usize::MAX` twice if none), over the runs from `starts` with summed scores `total(i)` that
/// pass `rise_ok(i)`, after the states `best(i, p)`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn dp_cell(
    grammar: &Grammar,
    s: usize,
    starts: std::ops::Range<usize>,
    total: impl Fn(usize) -> f64,
    rise_ok: impl Fn(usize) -> bool,
    best: impl Fn(usize, usize) -> f64,
    use_grammar: bool,
    penalty: f64,
) -> (f64, (usize, usize)) {
    let ns = grammar.n_skills();
    let mut top = f64::NEG_INFINITY;
    let mut arg = (usize::MAX, usize::MAX);
    for i in starts {
        if !rise_ok(i) {
            continue;
        }
        let c = total(i);
        if !c.is_finite() {
            continue;
        }
        if i == 0 {
            if (!use_grammar || grammar.allows(None, s)) && c - penalty > top {
                top = c - penalty;
                arg = (0, usize::MAX);
            }
            continue;
        }
        for p in 0..ns {
            let before = best(i, p);
            if !before.is_finite() || (use_grammar && !grammar.allows(Some(p), s)) {
                continue;
            }
            let v = before + c - penalty;
            if v > top {
                top = v;
                arg = (i, p);
            }
        }
    }
    (top, arg)
}

/// Best path as (skill, start section, end section) triples, or `None` if none is finite.
fn solve<V: AsRef<[f64]>>(
    ctx: &Context<'_, V>,
    use_rise: bool,
    use_grammar: bool,
    penalty: f64,
) -> Option<Vec<(usize, usize, usize)>> {
    let t = ctx.table;
    let k = t.n_sections();
    let ns = t.n_skills();
    // best[j * ns + s]: best score of sections 0..j ending with skill s; back: (i, prev skill)
    let mut best = vec![f64::NEG_INFINITY; (k + 1) * ns];
    let mut back = vec![(usize::MAX, usize::MAX); (k + 1) * ns];
    for j in 1..=k {
        for s in 0..ns {
            // runs outside the band score -inf: only the band's starts can end at j
            let (top, arg) = dp_cell(
                ctx.grammar,
                s,
                t.band().starts(j),
                |i| t.total(i, j, s),
                |i| !use_rise || ctx.rise_ok(i, j, s),
                |i, p| best[i * ns + p],
                use_grammar,
                penalty,
            );
            best[j * ns + s] = top;
            back[j * ns + s] = arg;
        }
    }
    let (mut s, mut top) = (usize::MAX, f64::NEG_INFINITY);
    for q in 0..ns {
        if best[k * ns + q] > top {
            top = best[k * ns + q];
            s = q;
        }
    }
    if !top.is_finite() {
        return None;
    }
    let mut path = Vec::new();
    let mut j = k;
    while j > 0 {
        let (i, p) = back[j * ns + s];
        path.push((s, i, j));
        j = i;
        s = p;
    }
    path.reverse();
    Some(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::grammar::tests::{paper_grammar, paper_skills};
    use crate::segment::greedy::{greedy, skills_of};

    fn ix(s: &str) -> usize {
        paper_skills().iter().position(|x| x == s).unwrap()
    }

    #[test]
    fn dp_finds_global_optimum_where_greedy_is_myopic() {
        // sections of 10 samples. Greedy sees a very good short prefix "push" on section 0 but
        // then must cover 1..4 badly; the global optimum is pick_up 0..2, move_with 2..4.
        let b: Vec<usize> = (0..=4).map(|x| x * 10).collect();
        let (pu, mw, push) = (ix("pick_up"), ix("move_with"), ix("push"));
        let t = ScoreTable::from_fn(b, 7, |i, j, s| {
            let n = (10 * (j - i)) as f64;
            let per = match (i, j) {
                (0, 1) if s == push => 0.5,
                (0, 2) if s == pu => 0.0,
                (2, 4) if s == mw => 0.0,
                _ => -3.0,
            };
            per * n
        })
        .unwrap();
        let g = paper_grammar();
        let gr = greedy(&t, &g, None, GrammarMode::Warn, false).unwrap();
        assert_eq!(gr.segments[0].skill, push);
        let d = dp(&t, &g, None, GrammarMode::Enforce, 1.0).unwrap();
        assert_eq!(skills_of(&d.segments), vec![pu, mw]);
        assert_eq!(d.segments[1].start_section, 2);
        assert!(d.warnings.is_empty());
    }

    #[test]
    fn penalty_trades_fit_against_number_of_segments() {
        // two sections; splitting gains 1 nat in total over a single move segment
        let b = vec![0, 10, 20];
        let mv = ix("move");
        let t = ScoreTable::from_fn(b, 7, |i, j, s| match (i, j, s) {
            (0, 2, x) if x == mv => -1.0,
            (0, 1, x) | (1, 2, x) if x == mv => 0.0,
            _ => -100.0,
        })
        .unwrap();
        let g = Grammar::permissive(&paper_skills());
        assert_eq!(
            dp(&t, &g, None, GrammarMode::Off, 0.0)
                .unwrap()
                .segments
                .len(),
            2
        );
        assert_eq!(
            dp(&t, &g, None, GrammarMode::Off, 2.0)
                .unwrap()
                .segments
                .len(),
            1
        );
        assert!(dp(&t, &g, None, GrammarMode::Off, f64::NAN).is_err());
    }

    #[test]
    fn relaxes_infeasible_grammar_with_warning() {
        // only "place" has finite scores: no grammar-valid path (place cannot start)
        let b = vec![0, 10];
        let t = ScoreTable::from_fn(b, 7, |_, _, s| {
            if s == ix("place") {
                -1.0
            } else {
                f64::NEG_INFINITY
            }
        })
        .unwrap();
        let d = dp(&t, &paper_grammar(), None, GrammarMode::Enforce, 0.0).unwrap();
        assert_eq!(skills_of(&d.segments), vec![ix("place")]);
        assert!(d.warnings.iter().any(|w| w.contains("grammar")));
    }

    proptest::proptest! {
        /// The confidence is the chosen skill's share of the candidates' posterior: a
        /// probability, at most 0.5 when a rival is at least as likely (margin <= 0).
        #[test]
        fn confidence_is_the_posterior_of_the_chosen_skill(
            per in proptest::collection::vec(-20.0f64..0.0, 7 * 3 * 4),
            enforce in proptest::bool::ANY,
        ) {
            let b = vec![0, 10, 20, 30];
            let t = ScoreTable::from_fn(b, 7, |i, j, s| {
                per[(i * 4 + j) * 7 + s] * (10 * (j - i)) as f64
            })
            .unwrap();
            let mode = if enforce { GrammarMode::Enforce } else { GrammarMode::Off };
            let d = dp(&t, &paper_grammar(), None, mode, 1.0).unwrap();
            for seg in &d.segments {
                let (i, j) = (seg.start_section, seg.end_section);
                proptest::prop_assert!((0.0..=1.0).contains(&seg.confidence));
                if seg.margin <= 0.0 {
                    proptest::prop_assert!(seg.confidence <= 0.5 + 1e-12);
                }
                let z: f64 = (0..7).map(|o| t.mean(i, j, o).exp()).sum();
                let want = t.mean(i, j, seg.skill).exp() / z;
                proptest::prop_assert!((seg.confidence - want).abs() < 1e-9);
            }
        }
    }
}
