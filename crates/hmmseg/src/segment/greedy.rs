//! The paper's greedy cut loop (Eq. 4-5): from the first unassigned data section, score every
//! prefix run of sections under every candidate skill, cut off the best (skill, run) and repeat
//! until all sections are assigned.
//!
//! Raw log-likelihoods fall with the number of samples, so prefixes of different lengths are
//! compared by their per-sample score ([`ScoreTable::mean`]). A per-sample score alone lets a run
//! win by swallowing easy samples of its neighbour (a Move across a Locate), or a skill win whose
//! only possible successor explains nothing (a Pick up where a Push is). With `lookahead` (the
//! default of the Python API) a candidate cut `(i..j, s)` is therefore valued by the per-sample
//! score of itself *together with the best next segment* `(j..j2, s2)` that may follow it (rise
//! decision, grammar when enforced, never the same skill twice):
//! `max_{j2, s2} (c^{i..j, s} + c^{j..j2, s2}) / n(i..j2)`. Only the first segment is cut; the loop
//! stays the paper's front-to-back cut of the best-scoring prefix (Eq. 4-5).

use super::{Context, Grammar, GrammarMode, ScoreTable, Segment, Segmentation};
use crate::error::Result;

/// Run the greedy loop.
///
/// * `rising` (one entry per run of the table's band, see [`super::rising_band`]) applies the Fig. 5 decision
///   tree: a rising run may only be a rising skill (Move, Move with), any other run only a
///   non-rising skill. `None` disables the tree.
/// * `mode`: [`GrammarMode::Enforce`] considers only allowed transitions; [`GrammarMode::Warn`]
///   keeps the best choice and reports impossible transitions.
///
/// * `lookahead`: value each candidate cut together with its best successor segment (see the
///   module documentation); `false` = the plain per-sample score of the prefix.
///
/// If no candidate passes the filters at some point, they are relaxed (rise decision first, then
/// the grammar) and a warning says so; the result always covers every section.
pub fn greedy<V: AsRef<[f64]>>(
    table: &ScoreTable<V>,
    grammar: &Grammar,
    rising: Option<&[bool]>,
    mode: GrammarMode,
    lookahead: bool,
) -> Result<Segmentation> {
    let ctx = Context::new(table, grammar, rising)?;
    let k = table.n_sections();
    let enforce = mode == GrammarMode::Enforce;
    let tiers: &[(bool, bool)] = if enforce {
        &[(true, true), (false, true), (true, false), (false, false)]
    } else {
        &[(true, false), (false, false)]
    };
    let mut out = Segmentation::default();
    let mut prev: Option<usize> = None;
    let mut i = 0;
    while i < k {
        let mut pick = None;
        for (tier, &(use_rise, use_grammar)) in tiers.iter().enumerate() {
            let mut best: Option<(f64, usize, usize)> = None;
            // runs outside the band score -inf: only its ends are candidates
            for j in table.band().ends(i) {
                for s in 0..table.n_skills() {
                    if (use_rise && !ctx.rise_ok(i, j, s))
                        || (use_grammar && !grammar.allows(prev, s))
                    {
                        continue;
                    }
                    let v = if lookahead {
                        with_successor(&ctx, i, j, s, use_grammar)
                    } else {
                        table.mean(i, j, s)
                    };
                    if v.is_finite() && best.is_none_or(|(b, _, _)| v > b) {
                        best = Some((v, j, s));
                    }
                }
            }
            if let Some((_, j, s)) = best {
                if tier > 0 {
                    out.warnings.push(format!(
                        "no candidate at samples {}.. satisfied the {}; relaxed it",
                        table.boundaries()[i],
                        match (use_rise, use_grammar) {
                            (false, true) => "TCP rise decision",
                            (true, false) => "grammar",
                            _ => "TCP rise decision and the grammar",
                        }
                    ));
                }
                pick = Some((j, s));
                break;
            }
        }
        // every score -inf (e.g. all runs longer than the maximum): take one section as it is
        let (j, s) = pick.unwrap_or_else(|| {
            out.warnings.push(format!(
                "no finite score at samples {}..; assigned one section to skill {}",
                table.boundaries()[i],
                grammar.skills()[0]
            ));
            (i + 1, 0)
        });
        out.segments.push(ctx.segment(s, i, j));
        prev = Some(s);
        i = j;
    }
    if mode == GrammarMode::Warn {
        out.warnings.extend(ctx.grammar_warnings(&out.segments));
    }
    Ok(out)
}

/// Per-sample score of the cut `(i..j, s)` together with its best successor `(j..j2, s2)`:
/// `max (c^{i..j, s} + c^{j..j2, s2}) / n(i..j2)` over successors of another skill that pass the
/// rise decision (relaxed if none does) and, with `use_grammar`, may follow `s`. A cut that ends
/// the demonstration is valued by its own per-sample score; `-inf` if no successor is finite.
fn with_successor<V: AsRef<[f64]>>(
    ctx: &Context<'_, V>,
    i: usize,
    j: usize,
    s: usize,
    use_grammar: bool,
) -> f64 {
    let table = ctx.table;
    let own = table.total(i, j, s);
    let k = table.n_sections();
    if !own.is_finite() || j == k {
        return table.mean(i, j, s);
    }
    for use_rise in [true, false] {
        let mut best = f64::NEG_INFINITY;
        for j2 in table.band().ends(j) {
            let n = table.len(i, j2) as f64;
            for s2 in 0..table.n_skills() {
                if s2 == s
                    || (use_rise && !ctx.rise_ok(j, j2, s2))
                    || (use_grammar && !ctx.grammar.allows(Some(s), s2))
                {
                    continue;
                }
                let next = table.total(j, j2, s2);
                if next.is_finite() {
                    best = best.max((own + next) / n);
                }
            }
        }
        if best.is_finite() {
            return best;
        }
    }
    f64::NEG_INFINITY
}

/// Skill sequence of a segmentation (helper for tests and tools).
pub fn skills_of(segments: &[Segment]) -> Vec<usize> {
    segments.iter().map(|s| s.skill).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::grammar::tests::{paper_grammar, paper_skills};

    fn ix(s: &str) -> usize {
        paper_skills().iter().position(|x| x == s).unwrap()
    }

    /// 6 sections of 10 samples; the truth is pick_up (0..2), move_with (2..3), place (3..4),
    /// move (4..6). A run scores 0 per sample for its true skill if it lies inside one true
    /// segment, -1 for every other skill, -5 when it spans two true segments.
    fn planted(truth: &[(usize, usize, usize)]) -> ScoreTable {
        let b: Vec<usize> = (0..=6).map(|x| x * 10).collect();
        ScoreTable::from_fn(b, 7, |i, j, s| {
            let inside = truth.iter().find(|&&(a, z, _)| a <= i && j <= z);
            let per = match inside {
                Some(&(a, z, t)) if t == s => {
                    if a == i && z == j {
                        0.0
                    } else {
                        -0.5
                    }
                }
                Some(_) => -1.0,
                None => -5.0,
            };
            per * (10 * (j - i)) as f64
        })
        .unwrap()
    }

    #[test]
    fn greedy_recovers_planted_segmentation() {
        let truth = [
            (0, 2, ix("pick_up")),
            (2, 3, ix("move_with")),
            (3, 4, ix("place")),
            (4, 6, ix("move")),
        ];
        let t = planted(&truth);
        let g = paper_grammar();
        let r = greedy(&t, &g, None, GrammarMode::Warn, false).unwrap();
        let got: Vec<(usize, usize, usize)> = r
            .segments
            .iter()
            .map(|s| (s.start_section, s.end_section, s.skill))
            .collect();
        assert_eq!(got, truth.to_vec());
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        assert!(r.segments.iter().all(|s| (s.margin - 1.0).abs() < 1e-12));
        // six rivals, each 1 nat per sample worse: 1 / (1 + 6 / e)
        let want = 1.0 / (1.0 + 6.0 * (-1.0f64).exp());
        assert!(r
            .segments
            .iter()
            .all(|s| (s.confidence - want).abs() < 1e-12));
        assert_eq!(r.segments[1].start, 20);
    }

    #[test]
    fn warn_reports_and_enforce_avoids_impossible_transition() {
        // make "place" the best skill for the very first section (place cannot start a demo)
        let mut t = planted(&[(0, 2, ix("pick_up")), (2, 6, ix("move_with"))]);
        t.set(0, 1, ix("place"), 1.0);
        let g = paper_grammar();
        let warn = greedy(&t, &g, None, GrammarMode::Warn, false).unwrap();
        assert_eq!(warn.segments[0].skill, ix("place"));
        assert!(
            warn.warnings.iter().any(|w| w.contains("start -> place")),
            "{:?}",
            warn.warnings
        );
        let enf = greedy(&t, &g, None, GrammarMode::Enforce, false).unwrap();
        assert_eq!(
            skills_of(&enf.segments),
            vec![ix("pick_up"), ix("move_with")]
        );
        assert!(enf.warnings.is_empty());
    }

    #[test]
    fn lookahead_recovers_planted_segmentation_too() {
        let truth = [
            (0, 2, ix("pick_up")),
            (2, 3, ix("move_with")),
            (3, 4, ix("place")),
            (4, 6, ix("move")),
        ];
        let t = planted(&truth);
        for mode in [GrammarMode::Warn, GrammarMode::Enforce] {
            let r = greedy(&t, &paper_grammar(), None, mode, true).unwrap();
            let got: Vec<(usize, usize, usize)> = r
                .segments
                .iter()
                .map(|s| (s.start_section, s.end_section, s.skill))
                .collect();
            assert_eq!(got, truth.to_vec());
        }
    }

    #[test]
    fn lookahead_stops_a_run_swallowing_its_neighbour() {
        // truth: move (0..1), locate (1..2), move (2..3). The long move 0..3 explains the locate
        // samples a little better per sample than the true move 0..1 does its own, so the plain
        // per-sample greedy swallows the locate; with its successor a locate, the short move wins.
        let (mv, lo) = (ix("move"), ix("locate"));
        let b: Vec<usize> = vec![0, 10, 20, 30];
        let t = ScoreTable::from_fn(b, 7, |i, j, s| {
            let n = (10 * (j - i)) as f64;
            let per = match (i, j) {
                (0, 1) | (2, 3) if s == mv => 1.0,
                (0, 3) if s == mv => 1.2,
                (1, 2) if s == lo => 3.0,
                _ => -5.0,
            };
            per * n
        })
        .unwrap();
        let g = paper_grammar();
        let plain = greedy(&t, &g, None, GrammarMode::Enforce, false).unwrap();
        assert_eq!(skills_of(&plain.segments), vec![mv]);
        let look = greedy(&t, &g, None, GrammarMode::Enforce, true).unwrap();
        assert_eq!(skills_of(&look.segments), vec![mv, lo, mv]);
        assert!(look.warnings.is_empty(), "{:?}", look.warnings);
    }

    #[test]
    fn rise_decision_restricts_candidates() {
        let t = planted(&[(0, 3, ix("place")), (3, 6, ix("pick_up"))]);
        let g = paper_grammar();
        // declare the whole demo rising: only move / move_with are candidates
        let rising = vec![true; t.band().n_runs()];
        let r = greedy(&t, &g, Some(&rising), GrammarMode::Off, false).unwrap();
        assert!(r.segments.iter().all(|s| g.is_rising(s.skill)));
        let not = vec![false; t.band().n_runs()];
        let r = greedy(&t, &g, Some(&not), GrammarMode::Off, false).unwrap();
        assert_eq!(skills_of(&r.segments), vec![ix("place"), ix("pick_up")]);
    }
}
