//! Stage 2 of the segmentation (paper Sec. III-B.4): merge the stage-1 data sections into skill
//! segments by HMM template matching.
//!
//! * [`grammar`]: the skill semantic ordering (Fig. 6) as data;
//! * [`templates`]: one HMM per skill x feature, trained by Baum-Welch, saved as versioned JSON;
//! * [`scores`]: the score table of Eq. 3 for every run of sections, and the TCP rise decision
//!   of Fig. 5;
//! * [`greedy`]: the paper's greedy cut loop (Eq. 4-5);
//! * [`dp`]: a globally optimal segmentation under the grammar (segmental dynamic programming).

pub mod dp;
pub mod grammar;
pub mod greedy;
pub mod scorer;
pub mod scores;
pub mod templates;

use serde::{Deserialize, Serialize};

pub use self::grammar::{Grammar, GrammarSpec};
pub use self::scores::{
    rising_band, rising_table, score_table, Band, PrefixScorer, RiseParams, ScoreTable,
};

/// How the skill grammar is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum GrammarMode {
    /// Ignore the grammar.
    Off,
    /// Keep the best segmentation; warn about every impossible transition (the paper).
    #[default]
    Warn,
    /// Consider only allowed transitions.
    Enforce,
}

crate::option_enum!(GrammarMode, "grammar mode", [Off => "off", Warn => "warn", Enforce => "enforce"]);

/// One skill segment of a result: sections `start_section..end_section`, samples `start..end`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    /// Skill index (grammar / template order).
    pub skill: usize,
    /// First data section.
    pub start_section: usize,
    /// One past the last data section.
    pub end_section: usize,
    /// First sample.
    pub start: usize,
    /// One past the last sample.
    pub end: usize,
    /// Summed feature log-likelihood per sample of the chosen skill.
    pub score: f64,
    /// Margin (per sample, nats) of `score` over the best other candidate skill on the same
    /// samples; `inf` without a rival, negative when a rival explains the samples better (the
    /// grammar or the rise decision chose this skill).
    pub margin: f64,
    /// Posterior probability, in `[0, 1]`, of the chosen skill among the candidate skills of the
    /// same samples (those passing the TCP-rise decision), from their per-sample scores with
    /// equal priors: `exp(score) / sum_o exp(score_o)`. 1 without a rival; at most 0.5 when a
    /// rival is at least as likely.
    pub confidence: f64,
}

/// The ordered segments covering the whole demonstration, and the warnings raised on the way.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Segmentation {
    /// Segments in time order.
    pub segments: Vec<Segment>,
    /// Human-readable warnings (impossible transitions, relaxed constraints).
    pub warnings: Vec<String>,
}

/// What restricts the candidate skills of a run of sections.
pub(crate) struct Context<'a, V = Vec<f64>> {
    pub table: &'a ScoreTable<V>,
    pub grammar: &'a Grammar,
    /// Is the TCP rising over sections `i..j`? One entry per run of the table's band (flat run
    /// order, see [`rising_band`]); `None` = no decision tree.
    pub rising: Option<&'a [bool]>,
}

impl<V: AsRef<[f64]>> Context<'_, V> {
    pub fn new<'a>(
        table: &'a ScoreTable<V>,
        grammar: &'a Grammar,
        rising: Option<&'a [bool]>,
    ) -> crate::Result<Context<'a, V>> {
        use crate::EngineError;
        if grammar.n_skills() != table.n_skills() {
            return Err(EngineError::ShapeMismatch(format!(
                "grammar has {} skills, score table {}",
                grammar.n_skills(),
                table.n_skills()
            )));
        }
        if let Some(r) = rising {
            let n = table.band().n_runs();
            if r.len() != n {
                return Err(EngineError::ShapeMismatch(format!(
                    "rising table has {} entries, expected {n} (one per run of the band)",
                    r.len(),
                )));
            }
        }
        Ok(Context {
            table,
            grammar,
            rising,
        })
    }

    /// Does skill `s` pass the TCP rise decision for sections `i..j`? (Never outside the band,
    /// where no run is scored.)
    pub fn rise_ok(&self, i: usize, j: usize, s: usize) -> bool {
        self.rising.is_none_or(|r| {
            self.table
                .band()
                .index(i, j)
                .is_some_and(|x| r[x] == self.grammar.is_rising(s))
        })
    }

    /// Margin of skill `s` over the best other skill passing the rise decision on `i..j`.
    pub fn margin(&self, i: usize, j: usize, s: usize) -> f64 {
        margin(
            self.table.n_skills(),
            s,
            |o| self.table.mean(i, j, o),
            |o| self.rise_ok(i, j, o),
        )
    }

    /// Posterior probability of skill `s` among the skills passing the rise decision on `i..j`
    /// (and `s` itself), from the per-sample scores with equal priors; 0 when `s` has no finite
    /// score.
    pub fn confidence(&self, i: usize, j: usize, s: usize) -> f64 {
        confidence(
            self.table.n_skills(),
            s,
            |o| self.table.mean(i, j, o),
            |o| self.rise_ok(i, j, o),
        )
    }

    pub fn segment(&self, s: usize, i: usize, j: usize) -> Segment {
        let b = self.table.boundaries();
        Segment {
            skill: s,
            start_section: i,
            end_section: j,
            start: b[i],
            end: b[j],
            score: self.table.mean(i, j, s),
            margin: self.margin(i, j, s),
            confidence: self.confidence(i, j, s),
        }
    }

    /// Warnings for transitions the grammar does not allow.
    pub fn grammar_warnings(&self, segments: &[Segment]) -> Vec<String> {
        let mut out = Vec::new();
        let mut prev = None;
        for (n, seg) in segments.iter().enumerate() {
            if !self.grammar.allows(prev, seg.skill) {
                out.push(format!(
                    "impossible skill transition {} (segment {n}, samples {}..{})",
                    self.grammar.describe(prev, seg.skill),
                    seg.start,
                    seg.end
                ));
            }
            prev = Some(seg.skill);
        }
        out
    }
}

/// Margin of skill `s` over the best other of `n_skills` skills passing `ok`, from the
/// per-sample scores `mean` of one run (see [`Segment::margin`]).
pub(crate) fn margin(
    n_skills: usize,
    s: usize,
    mean: impl Fn(usize) -> f64,
    ok: impl Fn(usize) -> bool,
) -> f64 {
    let best_other = (0..n_skills)
        .filter(|&o| o != s && ok(o))
        .map(&mean)
        .filter(|v| v.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    if best_other.is_finite() {
        mean(s) - best_other
    } else {
        f64::INFINITY
    }
}

/// Posterior probability of skill `s` among the skills passing `ok` (and `s` itself), from the
/// per-sample scores `mean` of one run with equal priors (see [`Segment::confidence`]).
pub(crate) fn confidence(
    n_skills: usize,
    s: usize,
    mean: impl Fn(usize) -> f64,
    ok: impl Fn(usize) -> bool,
) -> f64 {
    let own = mean(s);
    if !own.is_finite() {
        return 0.0;
    }
    // sum_o exp(score_o - score_s) over the rivals, plus 1 for s itself (stable: no overflow
    // of the largest term matters, 1 / inf = 0)
    let rivals: f64 = (0..n_skills)
        .filter(|&o| o != s && ok(o))
        .map(&mean)
        .filter(|v| v.is_finite())
        .map(|v| (v - own).exp())
        .sum();
    (1.0 / (1.0 + rivals)).clamp(0.0, 1.0)
}
