//! Online segmentation: stage 1, the stage-2 scores and the segmental DP fed one sample at a
//! time, while a demonstration is being recorded.
//!
//! Two halves, each the incremental form of the batch code it shares its arithmetic with:
//!
//! * [`OnlineScorer`] keeps the stage-1 crossing state ([`crate::stage1`]: hysteresis per
//!   criterion, minimum section length) and, per start section that a segment may still start
//!   from (at most `max_len` samples back, plus the open section), the forward state of every
//!   (skill, feature, object) template HMM and the TCP rise state. Each sample advances them by
//!   one step, so its cost is bounded by `max_len` and never grows with the demonstration's
//!   length. A boundary is *tentative* when its crossing is seen and *final* once `min_section`
//!   samples follow it (the batch rule keeps a cut that far from the end); then the band rows of
//!   the runs ending there are emitted ([`SectionRows`]: per start section, object and skill,
//!   the summed log-likelihood, and the rise decision), the same numbers as the batch table
//!   ([`super::scorer`], [`super::scores::rising_band`]).
//! * [`OnlineDp`] runs the segmental DP ([`super::dp`]) forward over the sections as their rows
//!   arrive (the caller adds evidence between the halves: the co-motion penalty and the maximum
//!   over target objects) and settles segments. A segment is emitted once every DP state that
//!   a future segment can still start from traces back through it (*traceback convergence*:
//!   the batch optimum then contains it too), or, at the latest, once its end is more than `lag`
//!   samples old: the best current path's oldest unsettled segment is then *forced*, and every
//!   state disagreeing with it is dropped. Emitted segments never change. [`OnlineDp::finish`]
//!   settles the best complete path: without forced settlements the whole sequence equals the
//!   batch DP's on the same table.

use std::collections::VecDeque;
use std::ops::Range;

use super::dp::{dp_cell, relaxed_warning, tiers};
use super::scorer::{CompiledHmm, EndState, ForwardState};
use super::scores::{RiseParams, RiseState};
use super::templates::{normalise, TemplateSet};
use super::{confidence, margin, Grammar, GrammarMode, Segment};
use crate::error::{EngineError, Result};
use crate::stage1::Stage1Params;

/// The leader rule does not settle a segment while a hypothesis within this many nats of the
/// best (or the beam, if narrower) has a segment going on across its end.
pub const ACROSS_BEAM: f64 = 20.0;

/// The band rows of the runs ending at one new section boundary.
#[derive(Debug, Clone, PartialEq)]
pub struct SectionRows {
    /// Index `j` of the boundary (section `j - 1` ends here).
    pub index: usize,
    /// The boundary's sample index `b_j`.
    pub bound: usize,
    /// The runs are `first_start..j` (one row per start section).
    pub first_start: usize,
    /// Number of target objects.
    pub n_objects: usize,
    /// Number of skills.
    pub n_skills: usize,
    /// Row-major `(R, n_objects, n_skills)`: summed log-likelihood of each run per object and
    /// skill (`-inf` where impossible).
    pub scores: Vec<f64>,
    /// `(R,)`: is the TCP rising over the run (paper Fig. 5)?
    pub rising: Vec<bool>,
}

/// Where a segment may start: a (tentative or final) boundary and the forward states from it.
#[derive(Debug, Clone)]
struct Start {
    section: usize,
    sample: usize,
    /// `[(s * F + f) * O + o]`; target-independent features only at `o = 0`.
    fwd: Vec<ForwardState>,
    rise: RiseState,
}

/// The tentative boundary and the rows of the runs ending there.
#[derive(Debug, Clone)]
struct Pending {
    cut: usize,
    rows: SectionRows,
}

/// Stage 1 and the stage-2 score rows, one sample at a time (see the module docs).
#[derive(Debug, Clone)]
pub struct OnlineScorer {
    models: Vec<Vec<CompiledHmm>>,
    groups: Vec<Range<usize>>,
    ranges: Vec<[f64; 2]>,
    shared: Vec<bool>,
    n_objects: usize,
    max_len: usize,
    end: EndState,
    rise: RiseParams,
    stage1: Stage1Params,
    n_stage1: usize,
    sides: Vec<Option<bool>>,
    n: usize,
    /// Final boundaries so far (`b_0 = 0` first).
    bounds: Vec<usize>,
    pending: Option<Pending>,
    starts: VecDeque<Start>,
    finished: bool,
    // scratch: scaled emissions `[(s * F + f) * O + o][state]` and their shifts
    em: Vec<f64>,
    shift: Vec<f64>,
    comp: Vec<f64>,
    row: Vec<f64>,
}

impl OnlineScorer {
    /// A scorer over the skill `templates` for `n_objects` target objects.
    ///
    /// * `shared[f]`: feature `f` of the templates does not depend on the target object (scored
    ///   once, like the batch pipeline's target-independent features; summed before the others);
    /// * `n_stage1`: columns of a stage-1 row; `stage1` its criteria (columns of that row);
    /// * `max_len`: longest run in samples (0: no bound); `end`, `rise`: as in the batch code.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        templates: &TemplateSet,
        shared: Vec<bool>,
        n_objects: usize,
        n_stage1: usize,
        stage1: Stage1Params,
        max_len: usize,
        end: EndState,
        rise: RiseParams,
    ) -> Result<Self> {
        let nf = templates.features.len();
        if shared.len() != nf {
            return Err(EngineError::ShapeMismatch(format!(
                "shared has {} entries for {nf} features",
                shared.len()
            )));
        }
        if n_objects == 0 {
            return Err(EngineError::InvalidParameter(
                "the online segmenter needs at least one object".into(),
            ));
        }
        if let Some(c) = stage1.criteria.iter().find(|c| c.column >= n_stage1) {
            return Err(EngineError::InvalidParameter(format!(
                "criterion column {} out of range for {n_stage1} stage-1 columns",
                c.column
            )));
        }
        if let Some(c) = stage1
            .criteria
            .iter()
            .find(|c| !c.hysteresis.is_finite() || c.hysteresis < 0.0)
        {
            return Err(EngineError::InvalidParameter(format!(
                "hysteresis must be finite and >= 0, got {}",
                c.hysteresis
            )));
        }
        let models = templates
            .models
            .iter()
            .map(|row| row.iter().map(CompiledHmm::new).collect::<Result<Vec<_>>>())
            .collect::<Result<Vec<_>>>()?;
        if models.iter().flatten().any(|m| m.n_states() > 16) {
            return Err(EngineError::InvalidParameter(
                "at most 16 states per template HMM".into(),
            ));
        }
        let groups = templates
            .features
            .iter()
            .map(super::templates::FeatureGroup::columns)
            .collect();
        let slots = models.len() * nf * n_objects;
        Ok(Self {
            models,
            groups,
            ranges: templates.ranges.clone(),
            shared,
            n_objects,
            max_len,
            end,
            rise,
            sides: vec![None; stage1.criteria.len()],
            stage1,
            n_stage1,
            n: 0,
            bounds: vec![0],
            pending: None,
            starts: VecDeque::new(),
            finished: false,
            em: vec![0.0; slots * 16],
            shift: vec![0.0; slots],
            comp: Vec::new(),
            row: Vec::new(),
        })
    }

    /// Samples consumed.
    pub fn n_samples(&self) -> usize {
        self.n
    }

    /// Final boundaries so far (`[0, b_1, ...]`).
    pub fn bounds(&self) -> &[usize] {
        &self.bounds
    }

    /// The tentative boundary, if any.
    pub fn tentative(&self) -> Option<usize> {
        self.pending.as_ref().map(|p| p.cut)
    }

    /// Number of start sections whose forward states are kept (bounded by `max_len`).
    pub fn n_active(&self) -> usize {
        self.starts.len()
    }

    fn n_features(&self) -> usize {
        self.groups.len()
    }

    fn min_section(&self) -> usize {
        self.stage1.min_section.max(1)
    }

    /// Consume one sample: `stage1_values` / `stage1_thresholds` the stage-1 row (NaN keeps a
    /// criterion's state), `obs` the raw feature rows with each object as the target
    /// (`n_objects` rows of the templates' columns, finite), `z` the TCP height. Returns the
    /// rows of a boundary that became final.
    pub fn push(
        &mut self,
        stage1_values: &[f64],
        stage1_thresholds: &[f64],
        obs: &[f64],
        z: f64,
    ) -> Result<Option<SectionRows>> {
        if self.finished {
            return Err(EngineError::InvalidParameter(
                "the online scorer has finished".into(),
            ));
        }
        let nc = self.ranges.len();
        if stage1_values.len() != self.n_stage1 || stage1_thresholds.len() != self.n_stage1 {
            return Err(EngineError::ShapeMismatch(format!(
                "stage-1 rows must have {} values, got {} and {}",
                self.n_stage1,
                stage1_values.len(),
                stage1_thresholds.len()
            )));
        }
        if obs.len() != self.n_objects * nc {
            return Err(EngineError::ShapeMismatch(format!(
                "observations must be {} objects x {nc} columns, got {} values",
                self.n_objects,
                obs.len()
            )));
        }
        if obs.iter().any(|v| !v.is_finite()) {
            return Err(EngineError::NonFinite(
                "observations contain NaN or infinity".into(),
            ));
        }
        let t = self.n;
        // stage 1: a crossing of any criterion at t (crate::stage1::crossings, one step)
        let mut cut = false;
        for (c, side) in self.stage1.criteria.iter().zip(&mut self.sides) {
            let (v, thr) = (stage1_values[c.column], stage1_thresholds[c.column]);
            if !v.is_finite() || !thr.is_finite() {
                continue;
            }
            match *side {
                None => *side = Some(v > thr),
                Some(true) if v < thr - c.hysteresis => {
                    *side = Some(false);
                    cut = true;
                }
                Some(false) if v > thr + c.hysteresis => {
                    *side = Some(true);
                    cut = true;
                }
                Some(_) => {}
            }
        }
        let last_kept = self.pending.as_ref().map_or(self.last_bound(), |p| p.cut);
        if cut && t > last_kept && t - last_kept >= self.min_section() {
            // crate::stage1::enforce_min_section: kept once min_section samples follow it
            let rows = self.rows_at(t, self.bounds.len());
            self.pending = Some(Pending { cut: t, rows });
            self.new_start(self.bounds.len(), t);
        }
        if self.starts.is_empty() {
            self.new_start(0, 0);
        }
        self.drop_old(t);
        self.advance(obs, z);
        self.n += 1;
        if let Some(p) = self.pending.take() {
            if self.n - p.cut >= self.min_section() {
                self.bounds.push(p.cut);
                return Ok(Some(p.rows));
            }
            self.pending = Some(p);
        }
        Ok(None)
    }

    /// End of the stream: a tentative boundary is dropped (too close to the end) and the rows of
    /// the runs ending at the last sample are returned.
    pub fn finish(&mut self) -> Result<SectionRows> {
        if self.finished {
            return Err(EngineError::InvalidParameter(
                "the online scorer has finished".into(),
            ));
        }
        if self.n == 0 {
            return Err(EngineError::EmptySequence(
                "stage 1 needs at least one sample".into(),
            ));
        }
        if self.pending.take().is_some() {
            self.starts.pop_back();
        }
        self.finished = true;
        let rows = self.rows_at(self.n, self.bounds.len());
        self.bounds.push(self.n);
        Ok(rows)
    }

    fn last_bound(&self) -> usize {
        self.bounds[self.bounds.len() - 1]
    }

    fn new_start(&mut self, section: usize, sample: usize) {
        let slots = self.models.len() * self.n_features() * self.n_objects;
        self.starts.push_back(Start {
            section,
            sample,
            fwd: vec![ForwardState::default(); slots],
            rise: RiseState::default(),
        });
    }

    /// Forget the starts no run through sample `t` can use: longer than `max_len`, unless the
    /// newest start or the newest final one (a tentative boundary may still be dropped).
    fn drop_old(&mut self, t: usize) {
        if self.max_len == 0 {
            return;
        }
        let keep_from = self.last_bound();
        while self.starts.len() > 1 {
            let s = &self.starts[0];
            if s.sample >= keep_from || t + 1 - s.sample <= self.max_len {
                break;
            }
            self.starts.pop_front();
        }
    }

    /// Advance every start by one sample.
    fn advance(&mut self, obs: &[f64], z: f64) {
        let (nf, no, nc) = (self.n_features(), self.n_objects, self.ranges.len());
        // normalise each object's row (templates::normalise on one row)
        self.row.clear();
        for o in 0..no {
            let raw = nalgebra::DMatrix::from_row_slice(1, nc, &obs[o * nc..(o + 1) * nc]);
            let x = normalise(&raw, &self.ranges).unwrap_or(raw);
            self.row.extend(x.iter().copied());
        }
        for (s, row) in self.models.iter().enumerate() {
            for (f, m) in row.iter().enumerate() {
                let g = &self.groups[f];
                let objects = if self.shared[f] { 1 } else { no };
                for o in 0..objects {
                    let slot = (s * nf + f) * no + o;
                    let x = &self.row[o * nc + g.start..o * nc + g.end];
                    self.shift[slot] =
                        m.scaled_emission(x, &mut self.em[slot * 16..], &mut self.comp);
                }
            }
        }
        for start in &mut self.starts {
            start.rise.push(z);
            for (s, row) in self.models.iter().enumerate() {
                for (f, m) in row.iter().enumerate() {
                    let objects = if self.shared[f] { 1 } else { no };
                    for o in 0..objects {
                        let slot = (s * nf + f) * no + o;
                        start.fwd[slot].step(
                            m,
                            &self.em[slot * 16..slot * 16 + m.n_states()],
                            self.shift[slot],
                        );
                    }
                }
            }
        }
    }

    /// The running scores: for every kept start at a final boundary `<= upto`, the summed
    /// log-likelihood of its samples so far under each object and skill (any end state): a
    /// segment still going on. Returns the start sections and row-major `(R, O, S)` scores.
    pub fn running(&self, upto: usize) -> (Vec<usize>, Vec<f64>) {
        let (nf, no) = (self.n_features(), self.n_objects);
        let pending = self.pending.as_ref().map(|p| p.cut);
        let mut sections = Vec::new();
        let mut out = Vec::new();
        for st in &self.starts {
            if st.section > upto || Some(st.sample) == pending {
                continue;
            }
            sections.push(st.section);
            for o in 0..no {
                for (s, row) in self.models.iter().enumerate() {
                    let (mut shared, mut rest) = (0.0, 0.0);
                    for (f, m) in row.iter().enumerate() {
                        if self.shared[f] {
                            shared += st.fwd[(s * nf + f) * no].value(m, EndState::Any);
                        } else {
                            rest += st.fwd[(s * nf + f) * no + o].value(m, EndState::Any);
                        }
                    }
                    let v = shared + rest;
                    out.push(if v.is_nan() { f64::NEG_INFINITY } else { v });
                }
            }
        }
        (sections, out)
    }

    /// The rows of the runs from every kept start ending at sample `b` (boundary `index`).
    fn rows_at(&self, b: usize, index: usize) -> SectionRows {
        let (ns, nf, no) = (self.models.len(), self.n_features(), self.n_objects);
        // the band: runs of at most max_len samples, and the newest start's single section
        let newest = self.starts.len().saturating_sub(1);
        let from = (0..self.starts.len())
            .find(|&x| {
                x == newest || self.max_len == 0 || b - self.starts[x].sample <= self.max_len
            })
            .unwrap_or(0);
        let first_start = self.starts.get(from).map_or(0, |s| s.section);
        let mut scores = Vec::with_capacity(self.starts.len() * no * ns);
        let mut rising = Vec::with_capacity(self.starts.len());
        for start in self.starts.iter().skip(from) {
            rising.push(start.rise.rising(self.rise));
            for o in 0..no {
                for (s, row) in self.models.iter().enumerate() {
                    // the batch sums: target-independent features, then the others, each from 0
                    // in feature order (NaN -> -inf per table)
                    let (mut shared, mut rest) = (0.0, 0.0);
                    let (mut any_shared, mut any_rest) = (false, false);
                    for (f, m) in row.iter().enumerate() {
                        if self.shared[f] {
                            shared += start.fwd[(s * nf + f) * no].value(m, self.end);
                            any_shared = true;
                        } else {
                            rest += start.fwd[(s * nf + f) * no + o].value(m, self.end);
                            any_rest = true;
                        }
                    }
                    let nan_inf = |v: f64| if v.is_nan() { f64::NEG_INFINITY } else { v };
                    scores.push(match (any_shared, any_rest) {
                        (true, true) => nan_inf(shared) + nan_inf(rest),
                        (true, false) => nan_inf(shared),
                        _ => nan_inf(rest),
                    });
                }
            }
        }
        SectionRows {
            index,
            bound: b,
            first_start,
            n_objects: no,
            n_skills: ns,
            scores,
            rising,
        }
    }
}

/// The best hypothesis with a segment going on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Leader {
    /// Not checked yet.
    Unknown,
    /// One segment from the start of the demonstration.
    Start,
    /// A DP state `(boundary, skill)` and a segment from there.
    State((usize, usize)),
}

/// Segments settled by the online DP, and how.
#[derive(Debug, Clone, PartialEq)]
pub struct Settled {
    /// The segment.
    pub segment: Segment,
    /// Settled by the lag bound rather than by agreement of every hypothesis.
    pub forced: bool,
}

/// The rows of the runs ending at one boundary, as the DP keeps them.
#[derive(Debug, Clone)]
struct Rows {
    first_start: usize,
    totals: Vec<f64>,
    rising: Vec<bool>,
}

/// The segmental DP over sections arriving one at a time (see the module docs).
#[derive(Debug, Clone)]
pub struct OnlineDp {
    grammar: Grammar,
    mode: GrammarMode,
    penalty: f64,
    max_len: usize,
    lag: usize,
    bounds: Vec<usize>,
    /// `rows[j]`: the runs ending at boundary `j` (`None` for `j = 0` and once settled past).
    rows: Vec<Option<Rows>>,
    tiers: Vec<(bool, bool)>,
    /// Per tier, `best[j * S + s]` and `back[j * S + s]` as in the batch DP.
    best: Vec<Vec<f64>>,
    back: Vec<Vec<(usize, usize)>>,
    /// The last settled boundary and the skill of the segment ending there.
    settled: (usize, Option<usize>),
    now: usize,
    finished: bool,
    warnings: Vec<String>,
    prev_skill: Option<usize>,
    count: usize,
    /// The best hypothesis's first unsettled node and the sample since which it leads.
    lead: Option<((usize, usize), usize)>,
    /// The state of the best hypothesis with a segment going on, from the last agreement
    /// check; the lag forces its path.
    leader: Leader,
    /// Per skill, the earliest end of a first unsettled segment of that skill among the
    /// hypotheses close to the best, from the last agreement check: forcing counts the lag from
    /// there (see [`OnlineDp::converge_running`]).
    earliest: Vec<Option<usize>>,
}

impl OnlineDp {
    /// A DP under `grammar` used as `mode`, with the batch DP's `penalty` and band `max_len`
    /// (samples, 0: none); a segment is forced at the latest `lag` samples after its end.
    pub fn new(
        grammar: Grammar,
        mode: GrammarMode,
        penalty: f64,
        max_len: usize,
        lag: usize,
    ) -> Result<Self> {
        if !penalty.is_finite() {
            return Err(EngineError::InvalidParameter(format!(
                "penalty must be finite, got {penalty}"
            )));
        }
        let tiers = tiers(mode).to_vec();
        let ns = grammar.n_skills();
        Ok(Self {
            grammar,
            mode,
            penalty,
            max_len,
            lag,
            bounds: vec![0],
            rows: vec![None],
            best: vec![vec![f64::NEG_INFINITY; ns]; tiers.len()],
            back: vec![vec![(usize::MAX, usize::MAX); ns]; tiers.len()],
            tiers,
            settled: (0, None),
            now: 0,
            finished: false,
            warnings: Vec::new(),
            prev_skill: None,
            count: 0,
            lead: None,
            leader: Leader::Unknown,
            earliest: vec![None; ns],
        })
    }

    fn ns(&self) -> usize {
        self.grammar.n_skills()
    }

    /// Number of skills.
    pub fn n_skills(&self) -> usize {
        self.grammar.n_skills()
    }

    /// Number of boundaries after `b_0`.
    pub fn n_sections(&self) -> usize {
        self.bounds.len() - 1
    }

    /// The warnings so far (impossible transitions with the grammar in `warn`, relaxed
    /// constraints, forced settlements).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The first start section of the runs ending at a new boundary `b` (the batch band).
    fn band_start(&self, b: usize) -> usize {
        let j = self.bounds.len();
        if self.max_len == 0 {
            return 0;
        }
        let mut i = j - 1;
        while i > 0 && b - self.bounds[i - 1] <= self.max_len {
            i -= 1;
        }
        i
    }

    /// Add the runs ending at the next boundary `bound`: `totals` row-major `(R, S)` for the
    /// starts `first_start..j`, `rising` `(R,)`; `now` is the number of samples seen. Returns the
    /// segments settled by it.
    pub fn add_section(
        &mut self,
        bound: usize,
        first_start: usize,
        totals: Vec<f64>,
        rising: Vec<bool>,
        now: usize,
    ) -> Result<Vec<Settled>> {
        if self.finished {
            return Err(EngineError::InvalidParameter(
                "the online DP has finished".into(),
            ));
        }
        let j = self.bounds.len();
        let last = self.bounds[j - 1];
        if bound <= last {
            return Err(EngineError::InvalidParameter(format!(
                "section boundaries must be strictly increasing: {bound} after {last}"
            )));
        }
        let want = self.band_start(bound);
        let ns = self.ns();
        let r = j - want;
        if first_start != want || totals.len() != r * ns || rising.len() != r {
            return Err(EngineError::ShapeMismatch(format!(
                "the runs ending at boundary {j} (sample {bound}) start at sections {want}..{j}: \
                 expected {r} x {ns} scores and {r} rise decisions from section {want}, got {} \
                 scores and {} from section {first_start}",
                totals.len(),
                rising.len()
            )));
        }
        if totals.iter().any(|v| v.is_nan()) {
            return Err(EngineError::NonFinite(
                "scores contain NaN (use -inf to exclude)".into(),
            ));
        }
        self.bounds.push(bound);
        self.rows.push(Some(Rows {
            first_start,
            totals,
            rising,
        }));
        for tier in 0..self.tiers.len() {
            let (use_rise, use_grammar) = self.tiers[tier];
            let rows = self.rows[j].as_ref().expect("just added");
            let best = &self.best[tier];
            let mut cells = Vec::with_capacity(ns);
            for s in 0..ns {
                cells.push(dp_cell(
                    &self.grammar,
                    s,
                    // nothing crosses a settled boundary (after a forced settlement; a
                    // converged one has no live state before it)
                    first_start.max(self.settled.0)..j,
                    |i| rows.totals[(i - first_start) * ns + s],
                    |i| !use_rise || rows.rising[i - first_start] == self.grammar.is_rising(s),
                    |i, p| best[i * ns + p],
                    use_grammar,
                    self.penalty,
                ));
            }
            for (top, arg) in cells {
                self.best[tier].push(top);
                self.back[tier].push(arg);
            }
        }
        self.now = self.now.max(now).max(bound);
        let mut out = self.converge();
        out.extend(self.force());
        Ok(out)
    }

    /// The clock moved to `now` samples: force what is older than the lag.
    pub fn tick(&mut self, now: usize) -> Vec<Settled> {
        if self.finished {
            return Vec::new();
        }
        self.now = self.now.max(now);
        self.force()
    }

    /// The first tier (constraints in the batch DP's relaxation order) that is still alive: a
    /// state a future run can start from is finite (or the start of the demonstration is).
    /// Without relaxation in the batch result this is the first tier throughout.
    fn active_tier(&self) -> Option<usize> {
        let ns = self.ns();
        let live = self.live();
        if self.settled.0 == 0 && live.contains(&0) {
            return Some(0);
        }
        (0..self.tiers.len()).find(|&t| {
            live.clone().any(|i| {
                self.best[t][i * ns..(i + 1) * ns]
                    .iter()
                    .any(|v| v.is_finite())
            })
        })
    }

    /// The first tier with a finite state at the last boundary (the batch DP's choice).
    fn final_tier(&self) -> Option<usize> {
        let (j, ns) = (self.n_sections(), self.ns());
        (0..self.tiers.len()).find(|&t| {
            self.best[t][j * ns..(j + 1) * ns]
                .iter()
                .any(|v| v.is_finite())
        })
    }

    /// The nodes `(boundary, skill)` after the settled one on the path to state `(j, s)`, in
    /// time order; `None` if it does not pass through the settled node.
    fn path(&self, tier: usize, mut j: usize, mut s: usize) -> Option<Vec<(usize, usize)>> {
        let ns = self.ns();
        let (sj, ss) = self.settled;
        let mut out = Vec::new();
        while j > sj {
            out.push((j, s));
            let (i, p) = self.back[tier][j * ns + s];
            if i == usize::MAX {
                return None;
            }
            j = i;
            s = p;
        }
        if j != sj || (sj > 0 && ss != Some(s)) {
            return None;
        }
        out.reverse();
        Some(out)
    }

    /// The boundaries a future run can start from (see the module docs).
    fn live(&self) -> Range<usize> {
        let j = self.n_sections();
        let mut lo = j;
        if self.max_len != 0 {
            let next = self.bounds[j] + 1;
            while lo > self.settled.0 && self.bounds[lo - 1].saturating_add(self.max_len) >= next {
                lo -= 1;
            }
        } else {
            lo = self.settled.0;
        }
        lo.max(self.settled.0)..j + 1
    }

    /// Settle the nodes every live state's path agrees on.
    fn converge(&mut self) -> Vec<Settled> {
        let Some(tier) = self.active_tier() else {
            return Vec::new();
        };
        let ns = self.ns();
        if self.settled.0 == 0 && self.live().contains(&0) {
            // the start of the demonstration is itself a live state (its path is empty)
            return Vec::new();
        }
        let mut common: Option<Vec<(usize, usize)>> = None;
        for i in self.live() {
            for p in 0..ns {
                if !self.best[tier][i * ns + p].is_finite() {
                    continue;
                }
                let Some(path) = self.path(tier, i, p) else {
                    continue;
                };
                common = Some(common_prefix(common, path));
                if common.as_ref().is_some_and(Vec::is_empty) {
                    return Vec::new();
                }
            }
        }
        common
            .unwrap_or_default()
            .into_iter()
            .map(|node| self.settle(node, false))
            .collect()
    }

    /// Settle what every hypothesis within `beam` nats of the best agrees on. A hypothesis is a
    /// live state followed by a segment still going on from it, scored over every sample so far
    /// (`running`: [`OnlineScorer::running`]), so hypotheses at different boundaries compare.
    /// States outside the beam are dropped once something settles (as after a forced
    /// settlement); an infinite beam is the exact agreement of every live state.
    ///
    /// With `stable` (samples, `Some`), the first unsettled segment of the best hypothesis also
    /// settles once it has stayed the same for that long (`now`: samples seen) and no hypothesis
    /// within the beam has a segment going on across its end: alternatives that differ only in
    /// where a boundary lies keep a bounded difference, which a beam does not resolve.
    pub fn converge_running(
        &mut self,
        sections: &[usize],
        running: &[f64],
        beam: f64,
        stable: Option<usize>,
        now: usize,
    ) -> Vec<Settled> {
        let Some(tier) = self.active_tier() else {
            return Vec::new();
        };
        let (_, use_grammar) = self.tiers[tier];
        let ns = self.ns();
        let (sj, _) = self.settled;
        // (state, score); None = the start of the demonstration
        let mut hyps: Vec<(Option<(usize, usize)>, f64)> = Vec::new();
        if running.len() != sections.len() * ns {
            return Vec::new();
        }
        for (&i, r) in sections.iter().zip(running.chunks_exact(ns)) {
            if i < sj || i > self.n_sections() {
                continue;
            }
            if i == 0 {
                let h = (0..ns)
                    .filter(|&s| !use_grammar || self.grammar.allows(None, s))
                    .map(|s| r[s] - self.penalty)
                    .fold(f64::NEG_INFINITY, f64::max);
                hyps.push((None, h));
                continue;
            }
            for p in 0..ns {
                let b = self.best[tier][i * ns + p];
                if !b.is_finite() {
                    continue;
                }
                let h = (0..ns)
                    .filter(|&s| !use_grammar || self.grammar.allows(Some(p), s))
                    .map(|s| b + r[s] - self.penalty)
                    .fold(f64::NEG_INFINITY, f64::max);
                hyps.push((Some((i, p)), h));
            }
        }
        let top = hyps.iter().map(|h| h.1).fold(f64::NEG_INFINITY, f64::max);
        if !top.is_finite() {
            return Vec::new();
        }
        // where the close hypotheses end their first unsettled segment, per skill: alternatives
        // that differ only in where a boundary lies take turns leading, and the lag then counts
        // from the earliest of them
        let near = beam.min(ACROSS_BEAM);
        self.earliest = vec![None; ns];
        for (state, h) in &hyps {
            let Some((i, p)) = *state else { continue };
            if *h < top - near {
                continue;
            }
            if let Some(&(j, s)) = self.path(tier, i, p).as_ref().and_then(|p| p.first()) {
                let end = self.bounds[j];
                self.earliest[s] = Some(self.earliest[s].map_or(end, |e| e.min(end)));
            }
        }
        self.leader = match hyps.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
            Some((Some(state), _)) => Leader::State(*state),
            Some((None, _)) => Leader::Start,
            None => Leader::Unknown,
        };
        if let Some(stable) = stable {
            // the leader's first unsettled node, and since when it leads
            let lead = hyps
                .iter()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .and_then(|h| h.0)
                .and_then(|(i, p)| self.path(tier, i, p))
                .and_then(|path| path.first().copied());
            match (lead, self.lead) {
                (Some(node), Some((old, _))) if node == old => {}
                (Some(node), _) => self.lead = Some((node, now)),
                (None, _) => self.lead = None,
            }
            // only boundary placement is decided so: no hypothesis within the beam may have a
            // segment still going on across the node's end
            let across = |node: (usize, usize)| {
                hyps.iter()
                    .any(|(state, h)| *h >= top - near && state.is_none_or(|(i, _)| i < node.0))
            };
            if let Some((node, since)) = self.lead {
                if now.saturating_sub(since) >= stable && !across(node) {
                    let old = self.settled.0;
                    let out = vec![self.settle(node, false)];
                    self.prune(old);
                    self.lead = None;
                    return out;
                }
            }
        }
        let mut common: Option<Vec<(usize, usize)>> = None;
        for (state, h) in &hyps {
            if h.is_nan() || *h < top - beam {
                continue;
            }
            let Some((i, p)) = *state else {
                return Vec::new(); // the start is itself in the beam: nothing is agreed
            };
            let Some(path) = self.path(tier, i, p) else {
                continue;
            };
            common = Some(common_prefix(common, path));
            if common.as_ref().is_some_and(Vec::is_empty) {
                return Vec::new();
            }
        }
        let nodes = common.unwrap_or_default();
        if nodes.is_empty() {
            return Vec::new();
        }
        let old = self.settled.0;
        let out = nodes.into_iter().map(|n| self.settle(n, false)).collect();
        self.prune(old);
        out
    }

    /// Force the best path's segments whose end is older than the lag (counted from the
    /// earliest end of the same skill among the close hypotheses of the last agreement check).
    fn force(&mut self) -> Vec<Settled> {
        let mut out = Vec::new();
        loop {
            // the best complete path (the batch DP's choice on the samples so far) past the lag;
            // past a sixth more, the best hypothesis with a segment going on (a hypothesis in
            // the middle of a skill scores the skill's first states only, so it may lead with a
            // skill the rest of the samples will not confirm)
            let leader = match self.leader {
                Leader::Start | Leader::Unknown => None,
                Leader::State((i, p)) => self.active_tier().and_then(|tier| self.path(tier, i, p)),
            };
            let complete = || {
                self.best_state()
                    .and_then(|(tier, j, s)| self.path(tier, j, s))
            };
            let old_enough = |path: &Option<Vec<(usize, usize)>>, lag: usize| {
                path.as_ref()
                    .and_then(|p| p.first().copied())
                    .filter(|&(j, s)| {
                        let end =
                            self.earliest[s].map_or(self.bounds[j], |e| e.min(self.bounds[j]));
                        self.now.saturating_sub(end) > lag
                    })
            };
            let node = old_enough(&complete(), self.lag)
                .or_else(|| old_enough(&leader, self.lag.saturating_add(self.lag / 6)));
            let Some(node) = node else {
                return out;
            };
            let old = self.settled.0;
            out.push(self.settle(node, true));
            self.prune(old);
        }
    }

    /// Drop every state whose path disagrees with the settled node.
    fn prune(&mut self, from: usize) {
        let ns = self.ns();
        let (sj, ss) = self.settled;
        for tier in 0..self.tiers.len() {
            for i in from..=self.n_sections() {
                for p in 0..ns {
                    let keep = match i.cmp(&sj) {
                        std::cmp::Ordering::Less => false,
                        std::cmp::Ordering::Equal => ss == Some(p),
                        std::cmp::Ordering::Greater => self.path(tier, i, p).is_some(),
                    };
                    if !keep {
                        self.best[tier][i * ns + p] = f64::NEG_INFINITY;
                    }
                }
            }
        }
    }

    /// Settle the segment from the settled boundary to `node` = `(j, s)`.
    fn settle(&mut self, (j, s): (usize, usize), forced: bool) -> Settled {
        let i = self.settled.0;
        let segment = self.segment(s, i, j);
        if self.mode == GrammarMode::Warn && !self.grammar.allows(self.prev_skill, s) {
            let n = self.n_settled_hint();
            self.warnings.push(format!(
                "impossible skill transition {} (segment {n}, samples {}..{})",
                self.grammar.describe(self.prev_skill, s),
                segment.start,
                segment.end
            ));
        }
        self.prev_skill = Some(s);
        self.earliest = vec![None; self.grammar.n_skills()];
        self.settled = (j, Some(s));
        self.count += 1;
        for r in &mut self.rows[i..=j] {
            *r = None;
        }
        Settled { segment, forced }
    }

    fn n_settled_hint(&self) -> usize {
        self.count
    }

    /// The segment of skill `s` over sections `i..j` with its metrics (as the batch DP's).
    fn segment(&self, s: usize, i: usize, j: usize) -> Segment {
        let ns = self.ns();
        let rows = self.rows[j].as_ref();
        let len = (self.bounds[j] - self.bounds[i]) as f64;
        // the run's per-sample scores and rise decision (none: outside the rows, -inf)
        let row = rows.filter(|r| i >= r.first_start).map(|r| {
            let x = i - r.first_start;
            (&r.totals[x * ns..(x + 1) * ns], r.rising[x])
        });
        let mean = |o: usize| row.map_or(f64::NEG_INFINITY, |(t, _)| t[o] / len);
        let ok = |o: usize| row.is_some_and(|(_, up)| up == self.grammar.is_rising(o));
        Segment {
            skill: s,
            start_section: i,
            end_section: j,
            start: self.bounds[i],
            end: self.bounds[j],
            score: mean(s),
            margin: margin(ns, s, mean, ok),
            confidence: confidence(ns, s, mean, ok),
        }
    }

    /// The first skill of the best state at boundary `j` (as the batch DP picks it).
    fn argmax(&self, tier: usize, j: usize) -> usize {
        let ns = self.ns();
        let (mut s, mut top) = (0, f64::NEG_INFINITY);
        for q in 0..ns {
            if self.best[tier][j * ns + q] > top {
                top = self.best[tier][j * ns + q];
                s = q;
            }
        }
        s
    }

    /// The best current path's last segment (skill, first sample, last boundary), if any.
    pub fn provisional(&self) -> Option<(usize, usize, usize)> {
        let (tier, j, s) = self.best_state()?;
        let (i, _) = self.back[tier][j * self.ns() + s];
        (i != usize::MAX).then(|| (s, self.bounds[i], self.bounds[j]))
    }

    /// The best current path's unsettled segments `(skill, start, end)` in time order.
    pub fn best_path(&self) -> Vec<(usize, usize, usize)> {
        let Some((tier, j, s)) = self.best_state() else {
            return Vec::new();
        };
        let mut prev = self.settled.0;
        self.path(tier, j, s)
            .unwrap_or_default()
            .into_iter()
            .map(|(j, s)| {
                let seg = (s, self.bounds[prev], self.bounds[j]);
                prev = j;
                seg
            })
            .collect()
    }

    /// The end state of the best current path: in the active tier, the best state at the last
    /// boundary, or at the latest live boundary with a finite state.
    fn best_state(&self) -> Option<(usize, usize, usize)> {
        let tier = self.active_tier()?;
        let ns = self.ns();
        self.live().rev().find_map(|j| {
            let s = self.argmax(tier, j);
            self.best[tier][j * ns + s]
                .is_finite()
                .then_some((tier, j, s))
        })
    }

    /// End of the stream (after the last boundary was added): settle the best complete path.
    pub fn finish(&mut self) -> Result<Vec<Settled>> {
        if self.finished {
            return Err(EngineError::InvalidParameter(
                "the online DP has finished".into(),
            ));
        }
        self.finished = true;
        let mut out = Vec::new();
        let j = self.n_sections();
        if j == self.settled.0 {
            return Ok(out);
        }
        if let Some(tier) = self.final_tier() {
            let (use_rise, use_grammar) = self.tiers[tier];
            if tier > 0 {
                self.warnings.push(relaxed_warning(use_rise, use_grammar));
            }
            let s = self.argmax(tier, j);
            if let Some(path) = self.path(tier, j, s) {
                for node in path {
                    out.push(self.settle(node, false));
                }
                return Ok(out);
            }
        }
        self.warnings
            .push("no finite score for any run of sections; output is a placeholder".into());
        for k in self.settled.0 + 1..=j {
            out.push(self.settle((k, 0), false));
        }
        Ok(out)
    }
}

/// The longest common prefix of `common` (None: none seen yet, then `path` itself) and `path`.
fn common_prefix<T: PartialEq>(common: Option<Vec<T>>, path: Vec<T>) -> Vec<T> {
    match common {
        None => path,
        Some(c) => c
            .into_iter()
            .zip(path)
            .take_while(|(a, b)| a == b)
            .map(|(a, _)| a)
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;
    use rand::{Rng, SeedableRng};

    use super::*;
    use crate::segment::dp::dp;
    use crate::segment::grammar::tests::{paper_grammar, paper_skills};
    use crate::segment::scores::{rising_band, Band, ScoreTable};
    use crate::segment::templates::tests::{examples, features, skills, small};
    use crate::stage1::{section_boundaries, Criterion};

    /// Feed a banded table section by section; `lag` in samples.
    #[allow(clippy::needless_range_loop)]
    fn online_dp(
        t: &ScoreTable,
        rising: &[bool],
        mode: GrammarMode,
        penalty: f64,
        lag: usize,
    ) -> (Vec<Settled>, Vec<usize>, Vec<String>) {
        let band = t.band();
        let ns = t.n_skills();
        let b = band.boundaries();
        let mut d = OnlineDp::new(paper_grammar(), mode, penalty, band.max_len(), lag).unwrap();
        let (mut out, mut when) = (Vec::new(), Vec::new());
        for j in 1..=band.n_sections() {
            let starts = band.starts(j);
            let first = starts.start;
            let mut totals = Vec::new();
            let mut rise = Vec::new();
            for i in starts {
                let r = band.index(i, j).unwrap();
                totals.extend((0..ns).map(|s| t.total(i, j, s)));
                rise.push(rising[r]);
            }
            // the settling clock: the boundary, plus a little (as the online scorer reports it)
            let now = b[j] + 3;
            for s in d.add_section(b[j], first, totals, rise, now).unwrap() {
                out.push(s);
                when.push(now);
            }
        }
        for s in d.finish().unwrap() {
            out.push(s);
            when.push(usize::MAX);
        }
        (out, when, d.warnings().to_vec())
    }

    fn random_table(seed: u64, k: usize, max_len: usize) -> (ScoreTable, Vec<bool>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut b = vec![0];
        for _ in 0..k {
            let last = *b.last().unwrap();
            b.push(last + rng.random_range(2..12));
        }
        let band = Band::new(b, max_len).unwrap();
        let n = band.n_runs();
        // a planted skill per section plus noise: paths of several segments win
        let plant: Vec<usize> = (0..k).map(|_| rng.random_range(0..7)).collect();
        let t = ScoreTable::from_band_fn(band.clone(), 7, |i, j, s| {
            let len = (band.boundaries()[j] - band.boundaries()[i]) as f64;
            let hits = (i..j).filter(|&x| plant[x] == s).count() as f64;
            let noise = ((i * 131 + j * 17 + s * 7 + seed as usize) % 97) as f64 / 97.0;
            if noise < 0.03 {
                f64::NEG_INFINITY
            } else {
                len * (-2.0 + hits / (j - i) as f64 * 1.5 - noise)
            }
        })
        .unwrap();
        let rising = (0..n).map(|_| rng.random_bool(0.4)).collect();
        (t, rising)
    }

    proptest::proptest! {
        /// Without forced settlements the online DP settles exactly the batch DP's segments
        /// (same numbers, same order), whatever the table, band, grammar mode and penalty.
        #[test]
        fn online_dp_equals_batch_dp(
            seed in 0u64..1_000_000,
            k in 1usize..40,
            max_len in proptest::sample::select(vec![0usize, 15, 30, 60]),
            mode in proptest::sample::select(vec![
                GrammarMode::Off, GrammarMode::Warn, GrammarMode::Enforce,
            ]),
            penalty in 0.0f64..20.0,
        ) {
            let (t, rising) = random_table(seed, k, max_len);
            let want = dp(&t, &paper_grammar(), Some(&rising), mode, penalty).unwrap();
            let (got, _, warnings) = online_dp(&t, &rising, mode, penalty, usize::MAX);
            proptest::prop_assert!(got.iter().all(|s| !s.forced));
            // a relaxed batch result (no complete path satisfies the constraints) may differ:
            // the online DP settles on the constraints while they can still be met
            proptest::prop_assume!(!want.warnings.iter().any(|w| w.contains("relaxed")));
            let segs: Vec<Segment> = got.into_iter().map(|s| s.segment).collect();
            proptest::prop_assert_eq!(&segs, &want.segments);
            let mut w = warnings.clone();
            w.sort();
            let mut v = want.warnings.clone();
            v.sort();
            proptest::prop_assert_eq!(w, v);
        }

        /// With a lag, every segment settles within it (of the boundary it ends at, at the
        /// section that carries the clock past it), the segments tile the samples in order, and
        /// nothing settled is changed (the settled list only grows).
        #[test]
        fn forced_settling_respects_the_lag(
            seed in 0u64..1_000_000,
            k in 2usize..40,
            lag in 0usize..30,
        ) {
            let (t, rising) = random_table(seed, k, 40);
            let (got, when, _) = online_dp(&t, &rising, GrammarMode::Enforce, 5.0, lag);
            let b = t.band().boundaries();
            let mut at = 0;
            for (s, &w) in got.iter().zip(&when) {
                proptest::prop_assert_eq!(s.segment.start, at);
                proptest::prop_assert!(s.segment.end > s.segment.start);
                at = s.segment.end;
                if w != usize::MAX {
                    // the best path's oldest unsettled segment ends within the lag, so every
                    // segment settles within lag + its longest length (40) + one section (12)
                    proptest::prop_assert!(w <= s.segment.start + lag + 40 + 12 + 3, "{w} {:?}", s);
                }
            }
            proptest::prop_assert_eq!(at, *b.last().unwrap());
        }
    }

    #[test]
    fn settles_before_the_end_when_hypotheses_agree() {
        // long, clear skills: most segments settle by agreement, long before the end
        let (t, rising) = random_table(7, 60, 40);
        let (got, when, _) = online_dp(&t, &rising, GrammarMode::Off, 5.0, usize::MAX);
        let early = when.iter().filter(|&&w| w != usize::MAX).count();
        assert!(early * 2 > got.len(), "{early} of {}", got.len());
    }

    #[test]
    fn bad_sections_are_errors() {
        let mut d = OnlineDp::new(paper_grammar(), GrammarMode::Enforce, 1.0, 0, 10).unwrap();
        assert!(d.add_section(0, 0, vec![0.0; 7], vec![false], 0).is_err());
        assert!(d.add_section(5, 0, vec![0.0; 6], vec![false], 5).is_err());
        assert!(d
            .add_section(5, 0, vec![f64::NAN; 7], vec![false], 5)
            .is_err());
        assert!(d.add_section(5, 0, vec![-1.0; 7], vec![false], 5).is_ok());
        assert!(d.add_section(9, 1, vec![-1.0; 7], vec![false], 9).is_err());
        assert!(OnlineDp::new(paper_grammar(), GrammarMode::Off, f64::NAN, 0, 1).is_err());
        let _ = paper_skills();
    }

    /// The online scorer's boundaries, rows and rise decisions equal the batch stage 1, score
    /// tables (target-independent features once, then the others) and `rising_band`.
    #[test]
    fn online_scorer_equals_batch_tables() {
        let set = TemplateSet::train(&skills(), &features(), &examples(), &small()).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (n, no) = (400, 2);
        // column 0 (feature "a", target-independent) shared; columns 1-2 per object
        let a: Vec<f64> = (0..n)
            .map(|t| (t as f64 / 17.0).sin() * 0.5 + 0.5 + rng.random_range(-0.05..0.05))
            .collect();
        let obs: Vec<DMatrix<f64>> = (0..no)
            .map(|o| {
                DMatrix::from_fn(n, 3, |t, c| match c {
                    0 => a[t],
                    _ => ((t as f64 + 40.0 * o as f64) / (9.0 + c as f64)).cos() * 0.4 + 0.5,
                })
            })
            .collect();
        // stage 1 on two square-ish waves with noise and a NaN
        let s1 = DMatrix::from_fn(n, 2, |t, c| {
            if t == 100 {
                f64::NAN
            } else {
                ((t as f64 / (11.0 + 6.0 * c as f64)).sin() + 0.1 * ((t * 7 % 5) as f64 - 2.0))
                    .max(-2.0)
            }
        });
        let th = DMatrix::from_element(n, 2, 0.0);
        let z: Vec<f64> = (0..n).map(|t| (t as f64 / 23.0).sin() * 0.05).collect();
        let params = Stage1Params {
            criteria: vec![
                Criterion {
                    column: 0,
                    hysteresis: 0.05,
                },
                Criterion {
                    column: 1,
                    hysteresis: 0.02,
                },
            ],
            min_section: 4,
        };
        let want_b = section_boundaries(&s1, &th, &params).unwrap();
        let rise = RiseParams {
            min_rise: 0.02,
            dominance: 0.5,
        };
        for (max_len, end) in [
            (60, EndState::Final),
            (0, EndState::Any),
            (25, EndState::Final),
        ] {
            let mut sc = OnlineScorer::new(
                &set,
                vec![true, false],
                no,
                2,
                params.clone(),
                max_len,
                end,
                rise,
            )
            .unwrap();
            let mut rows = Vec::new();
            for t in 0..n {
                let flat: Vec<f64> = (0..no)
                    .flat_map(|o| (0..3).map(move |c| (o, c)))
                    .map(|(o, c)| obs[o][(t, c)])
                    .collect();
                let v: Vec<f64> = s1.row(t).iter().copied().collect();
                rows.extend(sc.push(&v, &[0.0, 0.0], &flat, z[t]).unwrap());
                if max_len > 0 {
                    assert!(sc.n_active() <= max_len / 4 + 3);
                }
            }
            rows.push(sc.finish().unwrap());
            assert_eq!(sc.bounds(), &want_b[..]);
            let band = Band::new(want_b.clone(), max_len).unwrap();
            let rising = rising_band(&z, &band, rise).unwrap();
            let shared = set
                .score_table(&obs[0], &want_b, max_len, end, Some(&[0]))
                .unwrap();
            let rest: Vec<ScoreTable> = (0..no)
                .map(|o| {
                    set.score_table(&obs[o], &want_b, max_len, end, Some(&[1]))
                        .unwrap()
                })
                .collect();
            for r in &rows {
                let j = r.index;
                assert_eq!(r.first_start, band.starts(j).start);
                for (x, i) in band.starts(j).enumerate() {
                    assert_eq!(r.rising[x], rising[band.index(i, j).unwrap()]);
                    for (o, rest_o) in rest.iter().enumerate() {
                        for s in 0..2 {
                            let want = shared.total(i, j, s) + rest_o.total(i, j, s);
                            let got = r.scores[(x * no + o) * 2 + s];
                            assert!(
                                got.to_bits() == want.to_bits()
                                    || (got - want).abs() < 1e-9 * want.abs().max(1.0),
                                "run {i}..{j} object {o} skill {s}: {got} vs {want}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn scorer_rejects_bad_samples() {
        let set = TemplateSet::train(&skills(), &features(), &examples(), &small()).unwrap();
        let p = Stage1Params {
            criteria: vec![Criterion {
                column: 0,
                hysteresis: 0.0,
            }],
            min_section: 2,
        };
        let mk = || {
            OnlineScorer::new(
                &set,
                vec![true, false],
                1,
                1,
                p.clone(),
                10,
                EndState::Final,
                RiseParams::default(),
            )
        };
        let mut sc = mk().unwrap();
        assert!(sc.push(&[0.0], &[0.0], &[0.1, 0.2], 0.0).is_err());
        assert!(sc.push(&[0.0], &[0.0], &[0.1, f64::NAN, 0.2], 0.0).is_err());
        assert!(sc.finish().is_err()); // no sample yet
        let mut sc = mk().unwrap();
        sc.push(&[0.0], &[0.0], &[0.1, 0.2, 0.3], 0.0).unwrap();
        assert_eq!(sc.finish().unwrap().bound, 1);
        assert!(sc.push(&[0.0], &[0.0], &[0.1, 0.2, 0.3], 0.0).is_err());
        assert!(OnlineScorer::new(
            &set,
            vec![true],
            1,
            1,
            p.clone(),
            10,
            EndState::Final,
            RiseParams::default()
        )
        .is_err());
    }
}
