//! Skill templates (paper Sec. III-B.1-2): one HMM per skill x feature, trained with Baum-Welch
//! on the labelled segments of template demonstrations.
//!
//! Before training, every feature column is mapped to `[0, 1]` with a fixed range `[lo, hi]`
//! learned from the template set (robust percentiles), `clip((x - lo) / (hi - lo), 0, 1)`; the
//! same map is applied to new data at segmentation time, so a prefix of a normalised sequence is
//! the normalised prefix and prefix scores stay valid. Optionally every training sequence of a
//! skill x feature is warped by DTW onto the time axis of the medoid sequence first (the paper).
//!
//! A [`TemplateSet`] serialises to versioned JSON; reading another version, a skill the engine
//! does not know, an unknown field or a value out of range (an empty or inverted normalisation
//! range, a non-finite number, counts that do not match) is a [`EngineError::Format`] error.
//! Training parameters are checked by [`TemplateParams::validate`] and
//! [`TemplateParams::with_overrides`] ([`EngineError::InvalidParameter`]).

use std::ops::Range;

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::scorer::{compiled_score_table, CompiledHmm, EndState};
use super::scores::{score_table, PrefixScorer, ScoreTable};
use crate::dtw::{align_to_reference, dtw_distance};
use crate::error::{EngineError, Result};
use crate::hmm::{FitConfig, Hmm};
use crate::limits::at_most;

/// Version written into every template file; [`TemplateSet::from_json`] rejects any other.
pub const TEMPLATE_FORMAT_VERSION: u32 = 1;

/// The skills the engine knows (canonical names, `lfd.skills.SKILLS`).
pub const KNOWN_SKILLS: [&str; 7] = [
    "pick_up",
    "place",
    "locate",
    "stack",
    "push",
    "move",
    "move_with",
];

impl PrefixScorer for Hmm {
    fn prefix_scores(&self, x: &DMatrix<f64>) -> Result<DVector<f64>> {
        self.prefix_log_likelihoods(x)
    }
}

/// One feature of the templates: a name and the observation columns its HMM reads.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeatureGroup {
    /// Feature name (Table I).
    pub name: String,
    /// First column.
    pub start: usize,
    /// One past the last column.
    pub end: usize,
}

impl FeatureGroup {
    /// The column range.
    pub fn columns(&self) -> Range<usize> {
        self.start..self.end
    }
}

/// The most hidden states of one template HMM (`fit.n_states`). The shipped templates use 4
/// (one per phase of a skill); a few hundred samples per skill support far fewer than this,
/// and training time grows with it (`{"fit": {"n_states": 3000}}` ran for minutes).
pub const MAX_TEMPLATE_STATES: usize = 64;

/// The most Gaussian components per state of a template HMM (`fit.n_mix`). The shipped
/// templates use 2; more than this is refused before any recording is read.
pub const MAX_TEMPLATE_MIX: usize = 16;

/// How templates are trained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TemplateParams {
    /// Baum-Welch options (states, mixture components, topology, ...).
    pub fit: FitConfig,
    /// Warp the training sequences onto the medoid sequence by DTW before training.
    pub align: bool,
    /// Sakoe-Chiba band of the alignment DTW (samples), `None` = unbounded.
    pub dtw_band: Option<usize>,
    /// Percentiles (0-100) of the template samples that give each column's `[lo, hi]`.
    pub range_percentiles: [f64; 2],
}

impl Default for TemplateParams {
    fn default() -> Self {
        Self {
            fit: FitConfig {
                n_states: 4,
                n_mix: 2,
                // std >= 0.055 of a feature's template range: templates trained on one
                // demonstrator must not rule out a faster or noisier one (docs/segmentation.md:
                // 1e-3 loses whole pick-carry-place cycles on fast demonstrations)
                covariance_floor: 3e-3,
                ..FitConfig::default()
            },
            align: true,
            dtw_band: None,
            range_percentiles: [1.0, 99.0],
        }
    }
}

impl TemplateParams {
    /// Check every value: the fit options ([`FitConfig::validate`]) with at most
    /// [`MAX_TEMPLATE_STATES`] states and [`MAX_TEMPLATE_MIX`] components, a band of at least
    /// one sample, and percentiles `0 <= lo < hi <= 100`.
    pub fn validate(&self) -> Result<()> {
        let sizes = at_most(self.fit.n_states, MAX_TEMPLATE_STATES, "n_states")
            .and_then(|_| at_most(self.fit.n_mix, MAX_TEMPLATE_MIX, "n_mix"))
            .and_then(|_| self.fit.validate());
        sizes.map_err(|e| match e {
            EngineError::InvalidParameter(m) => EngineError::InvalidParameter(format!("fit: {m}")),
            other => other,
        })?;
        if self.dtw_band == Some(0) {
            return Err(EngineError::InvalidParameter(
                "dtw_band must be >= 1 sample (or null for no band)".into(),
            ));
        }
        let [lo, hi] = self.range_percentiles;
        if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi && hi <= 100.0) {
            return Err(EngineError::InvalidParameter(format!(
                "range_percentiles must be [lo, hi] with 0 <= lo < hi <= 100, got [{lo}, {hi}]"
            )));
        }
        Ok(())
    }

    /// The default parameters with `overrides` (a JSON object, possibly nested like
    /// `{"fit": {"n_states": 5}, "align": false}`) applied, then validated.
    ///
    /// An override naming a key the parameters do not have, at any level, a value of the wrong
    /// type and a value out of range are [`EngineError::InvalidParameter`] errors that name the
    /// key, e.g. `fit.n_states`.
    pub fn with_overrides(overrides: &str) -> Result<Self> {
        let bad = |m: String| EngineError::InvalidParameter(format!("template parameters: {m}"));
        let given: serde_json::Value =
            serde_json::from_str(overrides).map_err(|e| bad(format!("not valid JSON: {e}")))?;
        if !given.is_object() {
            return Err(bad(format!("must be a JSON object, got {given}")));
        }
        let mut merged =
            serde_json::to_value(Self::default()).map_err(|e| bad(format!("defaults: {e}")))?;
        merge_params(&mut merged, &given, "")?;
        // a wrong type names its key: `template parameter `fit.n_states`: invalid type ...`
        let params: Self = serde_path_to_error::deserialize(merged).map_err(|e| {
            EngineError::InvalidParameter(format!(
                "template parameter `{}`: {}",
                e.path(),
                e.inner()
            ))
        })?;
        params.validate().map_err(|e| match e {
            EngineError::InvalidParameter(m) => bad(m),
            other => other,
        })?;
        Ok(params)
    }
}

/// Apply `given` onto `target` (the defaults), recursing into objects; every key must exist in
/// `target`.
fn merge_params(
    target: &mut serde_json::Value,
    given: &serde_json::Value,
    prefix: &str,
) -> Result<()> {
    let (Some(t), Some(g)) = (target.as_object_mut(), given.as_object()) else {
        return Ok(());
    };
    for (key, value) in g {
        let path = if prefix.is_empty() {
            key.clone()
        } else {
            format!("{prefix}.{key}")
        };
        let Some(slot) = t.get_mut(key) else {
            let mut known: Vec<&String> = t.keys().collect();
            known.sort();
            let known: Vec<&str> = known.iter().map(|k| k.as_str()).collect();
            return Err(EngineError::InvalidParameter(format!(
                "unknown template parameter `{path}` (known{}: {})",
                if prefix.is_empty() {
                    String::new()
                } else {
                    format!(" in `{prefix}`")
                },
                known.join(", ")
            )));
        };
        if slot.is_object() {
            if !value.is_object() {
                return Err(EngineError::InvalidParameter(format!(
                    "template parameter `{path}` must be a JSON object, got {value}"
                )));
            }
            merge_params(slot, value, &path)?;
        } else {
            *slot = value.clone();
        }
    }
    Ok(())
}

/// A trained template set: `models[skill][feature]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemplateSet {
    /// Must equal [`TEMPLATE_FORMAT_VERSION`].
    pub format_version: u32,
    /// Skill names, in model order.
    pub skills: Vec<String>,
    /// Features, in model order.
    pub features: Vec<FeatureGroup>,
    /// `[lo, hi]` of every observation column.
    pub ranges: Vec<[f64; 2]>,
    /// Training options.
    pub params: TemplateParams,
    /// Training segments per skill.
    pub n_examples: Vec<usize>,
    /// One HMM per skill x feature.
    pub models: Vec<Vec<Hmm>>,
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let pos = (p / 100.0).clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (a, b) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[a] + (sorted[b] - sorted[a]) * (pos - a as f64)
}

/// Map every column to `[0, 1]` with fixed ranges: `clip((x - lo) / (hi - lo), 0, 1)`; a column
/// with `hi <= lo` becomes 0.5. NaN stays NaN.
pub fn normalise(x: &DMatrix<f64>, ranges: &[[f64; 2]]) -> Result<DMatrix<f64>> {
    if x.ncols() != ranges.len() {
        return Err(EngineError::ShapeMismatch(format!(
            "{} columns but {} ranges",
            x.ncols(),
            ranges.len()
        )));
    }
    let mut out = x.clone();
    for (j, mut c) in out.column_iter_mut().enumerate() {
        let [lo, hi] = ranges[j];
        let span = hi - lo;
        c.apply(|v| {
            *v = if span > 0.0 {
                ((*v - lo) / span).clamp(0.0, 1.0)
            } else {
                0.5
            };
        });
    }
    Ok(out)
}

fn medoid(seqs: &[DMatrix<f64>], band: Option<usize>) -> Result<usize> {
    let n = seqs.len();
    let mut cost = vec![0.0; n];
    for a in 0..n {
        for b in a + 1..n {
            let d = dtw_distance(&seqs[a], &seqs[b], band)?;
            cost[a] += d;
            cost[b] += d;
        }
    }
    Ok(cost
        .iter()
        .enumerate()
        .min_by(|x, y| x.1.total_cmp(y.1))
        .map_or(0, |(i, _)| i))
}

/// Check labelled examples against the skills and features; returns the number of observation
/// columns and the number of examples per skill (every skill needs one).
fn check_examples(
    skills: &[String],
    features: &[FeatureGroup],
    examples: &[(usize, DMatrix<f64>)],
) -> Result<(usize, Vec<usize>)> {
    if features.is_empty() {
        return Err(EngineError::EmptySequence("no features".into()));
    }
    if let Some(f) = features.iter().find(|f| f.start >= f.end) {
        return Err(EngineError::InvalidParameter(format!(
            "feature {:?} has no columns",
            f.name
        )));
    }
    let n_cols = features.iter().map(|f| f.end).max().unwrap_or(0);
    for (k, (s, x)) in examples.iter().enumerate() {
        if *s >= skills.len() {
            return Err(EngineError::InvalidParameter(format!(
                "example {k} has skill index {s}, only {} skills",
                skills.len()
            )));
        }
        if x.ncols() != n_cols {
            return Err(EngineError::ShapeMismatch(format!(
                "example {k} has {} columns, features need {n_cols}",
                x.ncols()
            )));
        }
        if x.nrows() == 0 {
            return Err(EngineError::EmptySequence(format!(
                "example {k} has no samples"
            )));
        }
        if x.iter().any(|v| !v.is_finite()) {
            return Err(EngineError::NonFinite(format!(
                "example {k} contains NaN or inf"
            )));
        }
    }
    let mut n_examples = vec![0; skills.len()];
    for (s, _) in examples {
        n_examples[*s] += 1;
    }
    if let Some(s) = n_examples.iter().position(|&c| c == 0) {
        return Err(EngineError::EmptySequence(format!(
            "no examples of skill {:?}",
            skills[s]
        )));
    }
    Ok((n_cols, n_examples))
}

/// Fixed per-column normalisation ranges: the `[lo, hi]` percentiles of all example samples.
fn column_ranges(
    examples: &[(usize, DMatrix<f64>)],
    n_cols: usize,
    [p_lo, p_hi]: [f64; 2],
) -> Vec<[f64; 2]> {
    (0..n_cols)
        .map(|c| {
            let mut v: Vec<f64> = examples
                .iter()
                .flat_map(|(_, x)| x.column(c).iter().copied().collect::<Vec<_>>())
                .collect();
            v.sort_by(f64::total_cmp);
            [percentile(&v, p_lo), percentile(&v, p_hi)]
        })
        .collect()
}

/// The template of skill `s` for feature group `feature`: its normalised examples (restricted
/// to the group's columns and, with `params.align`, DTW-aligned to their medoid) fitted by
/// Baum-Welch with at most as many states as the shortest example has samples.
fn fit_template(
    s: usize,
    f: usize,
    feature: &FeatureGroup,
    normed: &[(usize, DMatrix<f64>)],
    params: &TemplateParams,
) -> Result<Hmm> {
    let cols = feature.columns();
    let seqs: Vec<DMatrix<f64>> = normed
        .iter()
        .filter(|(k, _)| *k == s)
        .map(|(_, x)| x.columns(cols.start, cols.len()).into_owned())
        .collect();
    let seqs = if params.align && seqs.len() > 1 {
        let m = medoid(&seqs, params.dtw_band)?;
        align_to_reference(&seqs[m], &seqs, params.dtw_band)?
    } else {
        seqs
    };
    let shortest = seqs.iter().map(DMatrix::nrows).min().unwrap_or(1);
    let mut cfg = params.fit.clone();
    // a segment shorter than n_states cannot visit every state of a left-right model
    cfg.n_states = cfg.n_states.min(shortest);
    cfg.seed = params.fit.seed.wrapping_add((s * 1000 + f) as u64);
    Hmm::fit(&seqs, &cfg).map(|(hmm, _)| hmm)
}

impl TemplateSet {
    /// Train templates.
    ///
    /// * `skills`: skill names (each must be one of [`KNOWN_SKILLS`]);
    /// * `examples`: `(skill index, raw observations n x C)` labelled segments;
    /// * `features`: the HMM feature groups over the `C` columns.
    pub fn train(
        skills: &[String],
        features: &[FeatureGroup],
        examples: &[(usize, DMatrix<f64>)],
        params: &TemplateParams,
    ) -> Result<Self> {
        check_skills(skills)?;
        params.validate()?;
        let (n_cols, n_examples) = check_examples(skills, features, examples)?;
        let ranges = column_ranges(examples, n_cols, params.range_percentiles);
        let normed: Vec<(usize, DMatrix<f64>)> = examples
            .iter()
            .map(|(s, x)| Ok((*s, normalise(x, &ranges)?)))
            .collect::<Result<_>>()?;
        let jobs: Vec<(usize, usize)> = (0..skills.len())
            .flat_map(|s| (0..features.len()).map(move |f| (s, f)))
            .collect();
        let fitted: Vec<Result<Hmm>> = jobs
            .par_iter()
            .map(|&(s, f)| {
                fit_template(s, f, &features[f], &normed, params).map_err(|e| match e {
                    EngineError::InvalidParameter(m) => EngineError::InvalidParameter(format!(
                        "skill {:?}, feature {:?}: {m}",
                        skills[s], features[f].name
                    )),
                    other => other,
                })
            })
            .collect();
        let mut models: Vec<Vec<Hmm>> = vec![Vec::with_capacity(features.len()); skills.len()];
        for ((s, _), m) in jobs.iter().zip(fitted) {
            models[*s].push(m?);
        }
        Ok(Self {
            format_version: TEMPLATE_FORMAT_VERSION,
            skills: skills.to_vec(),
            features: features.to_vec(),
            ranges,
            params: params.clone(),
            n_examples,
            models,
        })
    }

    /// Normalise raw observations (`n x C`) with the template ranges.
    pub fn normalise(&self, x: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        normalise(x, &self.ranges)
    }

    /// The score table of raw (un-normalised) observations over stage-1 `boundaries`; `end`
    /// chooses which HMM states may end a segment. `features` (indices into
    /// [`Self::features`]) restricts the sum to some features; `None` = all.
    pub fn score_table(
        &self,
        raw: &DMatrix<f64>,
        boundaries: &[usize],
        max_len: usize,
        end: EndState,
        features: Option<&[usize]>,
    ) -> Result<ScoreTable> {
        let x = self.normalise(raw)?;
        let all: Vec<usize> = (0..self.features.len()).collect();
        let chosen = features.unwrap_or(&all);
        if chosen.is_empty() {
            return Err(EngineError::EmptySequence("no features chosen".into()));
        }
        if let Some(f) = chosen.iter().find(|&&f| f >= self.features.len()) {
            return Err(EngineError::InvalidParameter(format!(
                "feature index {f} out of range for {} features",
                self.features.len()
            )));
        }
        let groups: Vec<Range<usize>> =
            chosen.iter().map(|&f| self.features[f].columns()).collect();
        let compiled = self
            .models
            .iter()
            .map(|row| {
                chosen
                    .iter()
                    .map(|&f| CompiledHmm::new(&row[f]))
                    .collect::<Result<Vec<_>>>()
            })
            .collect::<Result<Vec<_>>>()?;
        compiled_score_table(&compiled, &groups, &x, boundaries, max_len, end)
    }

    /// [`Self::score_table`] through the engine's generic forward pass (`ln P(x_0..=t)`, any end
    /// state); a slower reference.
    pub fn score_table_reference(
        &self,
        raw: &DMatrix<f64>,
        boundaries: &[usize],
        max_len: usize,
    ) -> Result<ScoreTable> {
        let x = self.normalise(raw)?;
        let groups: Vec<Range<usize>> = self.features.iter().map(FeatureGroup::columns).collect();
        score_table(&self.models, &groups, &x, boundaries, max_len)
    }

    /// Serialise to JSON.
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string(self).map_err(|e| EngineError::Format(format!("templates: {e}")))
    }

    /// Read templates from JSON, checking the version, the skills and the shapes.
    pub fn from_json(text: &str) -> Result<Self> {
        #[derive(Deserialize)]
        struct Head {
            format_version: Option<u32>,
        }
        let head: Head = serde_json::from_str(text)
            .map_err(|e| EngineError::Format(format!("template file is not valid JSON: {e}")))?;
        match head.format_version {
            Some(TEMPLATE_FORMAT_VERSION) => {}
            Some(v) => {
                return Err(EngineError::Format(format!(
                    "template file has format_version {v}; this version of lfd reads version \
                     {TEMPLATE_FORMAT_VERSION} (retrain with `lfd templates train`)"
                )))
            }
            None => {
                return Err(EngineError::Format(
                    "template file has no format_version".into(),
                ))
            }
        }
        // the error names the field (`models[3][1].transitions: invalid type ...`)
        let set: Self =
            serde_path_to_error::deserialize(&mut serde_json::Deserializer::from_str(text))
                .map_err(|e| {
                    EngineError::Format(format!("template file: {}: {}", e.path(), e.inner()))
                })?;
        check_skills(&set.skills)?;
        set.check_contents()?;
        let n_cols = set.features.iter().map(|f| f.end).max().unwrap_or(0);
        if set.ranges.len() != n_cols {
            return Err(EngineError::Format(format!(
                "template file has {} ranges for {n_cols} columns",
                set.ranges.len()
            )));
        }
        if set.models.len() != set.skills.len()
            || set.models.iter().any(|m| m.len() != set.features.len())
        {
            return Err(EngineError::Format(
                "template file: models do not match skills x features".into(),
            ));
        }
        for (s, row) in set.models.iter().enumerate() {
            for (f, m) in row.iter().enumerate() {
                if m.n_features() != set.features[f].end - set.features[f].start {
                    return Err(EngineError::Format(format!(
                        "template file: model {}/{} has the wrong dimension",
                        set.skills[s], set.features[f].name
                    )));
                }
            }
        }
        Ok(set)
    }
}

impl TemplateSet {
    /// The checks of a read template file beyond its shape: features with columns and distinct
    /// names, finite ranges with `lo < hi`, one example count per skill, valid parameters.
    fn check_contents(&self) -> Result<()> {
        let bad = |m: String| EngineError::Format(format!("template file: {m}"));
        if self.features.is_empty() {
            return Err(bad("no features".into()));
        }
        for (i, f) in self.features.iter().enumerate() {
            if f.start >= f.end {
                return Err(bad(format!(
                    "feature {:?} has no columns ({}..{})",
                    f.name, f.start, f.end
                )));
            }
            if self.features[..i].iter().any(|g| g.name == f.name) {
                return Err(bad(format!("feature {:?} appears twice", f.name)));
            }
        }
        for (c, [lo, hi]) in self.ranges.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite()) {
                return Err(bad(format!(
                    "range of column {c} is [{lo}, {hi}]; both ends must be finite"
                )));
            }
            if lo >= hi {
                return Err(bad(format!(
                    "range of column {c} is [{lo}, {hi}], which is empty or inverted (needs lo < hi)"
                )));
            }
        }
        if self.n_examples.len() != self.skills.len() {
            return Err(bad(format!(
                "{} example counts for {} skills",
                self.n_examples.len(),
                self.skills.len()
            )));
        }
        if let Some(s) = self.n_examples.iter().position(|&n| n == 0) {
            return Err(bad(format!(
                "skill {:?} has no training examples",
                self.skills[s]
            )));
        }
        self.params
            .validate()
            .map_err(|e| bad(format!("params: {e}")))
    }
}

fn check_skills(skills: &[String]) -> Result<()> {
    if skills.is_empty() {
        return Err(EngineError::EmptySequence("no skills".into()));
    }
    for s in skills {
        if !KNOWN_SKILLS.contains(&s.as_str()) {
            return Err(EngineError::Format(format!(
                "unknown skill {s:?} (known: {})",
                KNOWN_SKILLS.join(", ")
            )));
        }
    }
    for (i, s) in skills.iter().enumerate() {
        if skills[..i].contains(s) {
            return Err(EngineError::Format(format!("skill {s:?} appears twice")));
        }
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn skills() -> Vec<String> {
        vec!["pick_up".into(), "move".into()]
    }

    pub(crate) fn features() -> Vec<FeatureGroup> {
        vec![
            FeatureGroup {
                name: "a".into(),
                start: 0,
                end: 1,
            },
            FeatureGroup {
                name: "b".into(),
                start: 1,
                end: 3,
            },
        ]
    }

    /// pick_up: column 0 falls 1 -> 0; move: column 0 rises 0 -> 1. Columns 1-2 noise-free ramps.
    pub(crate) fn examples() -> Vec<(usize, DMatrix<f64>)> {
        let mut out = Vec::new();
        for k in 0..4 {
            let n = 20 + 3 * k;
            let ramp = |t: usize| t as f64 / (n - 1) as f64 + 0.01 * k as f64;
            out.push((
                0,
                DMatrix::from_fn(n, 3, |t, c| {
                    if c == 0 {
                        1.0 - ramp(t)
                    } else {
                        ramp(t) * c as f64
                    }
                }),
            ));
            out.push((
                1,
                DMatrix::from_fn(n, 3, |t, c| if c == 0 { ramp(t) } else { 0.5 }),
            ));
        }
        out
    }

    pub(crate) fn small() -> TemplateParams {
        TemplateParams {
            fit: FitConfig {
                n_states: 3,
                n_mix: 1,
                max_iter: 20,
                ..FitConfig::default()
            },
            ..TemplateParams::default()
        }
    }

    #[test]
    fn train_classify_and_round_trip() {
        let set = TemplateSet::train(&skills(), &features(), &examples(), &small()).unwrap();
        assert_eq!(set.n_examples, vec![4, 4]);
        // a falling then a rising column-0 sequence: two sections, each best under its skill
        let n = 22;
        let x = DMatrix::from_fn(2 * n, 3, |t, c| {
            let r = (t % n) as f64 / (n - 1) as f64;
            match (t < n, c) {
                (true, 0) => 1.0 - r,
                (true, _) => r * c as f64,
                (false, 0) => r,
                (false, _) => 0.5,
            }
        });
        let table = set
            .score_table(&x, &[0, n, 2 * n], 0, EndState::Any, None)
            .unwrap();
        let reference = set.score_table_reference(&x, &[0, n, 2 * n], 0).unwrap();
        for (a, b) in table.as_slice().iter().zip(reference.as_slice()) {
            let same_inf = a.is_infinite() && b.is_infinite();
            assert!(
                same_inf || (a - b).abs() < 1e-8 * a.abs().max(1.0),
                "{a} vs {b}"
            );
        }
        let fin = set
            .score_table(&x, &[0, n, 2 * n], 0, EndState::Final, None)
            .unwrap();
        assert!(fin.mean(0, 1, 0) > fin.mean(0, 1, 1));
        // the sum over features splits into the sums over any partition of them
        let b3 = [0, n, 2 * n];
        let a = set
            .score_table(&x, &b3, 0, EndState::Final, Some(&[0]))
            .unwrap();
        let b = set
            .score_table(&x, &b3, 0, EndState::Final, Some(&[1]))
            .unwrap();
        assert!((a.total(0, 1, 0) + b.total(0, 1, 0) - fin.total(0, 1, 0)).abs() < 1e-9);
        assert!(set
            .score_table(&x, &b3, 0, EndState::Final, Some(&[5]))
            .is_err());
        assert!(table.mean(0, 1, 0) > table.mean(0, 1, 1));
        assert!(table.mean(1, 2, 1) > table.mean(1, 2, 0));
        let json = set.to_json().unwrap();
        let back = TemplateSet::from_json(&json).unwrap();
        assert_eq!(back.skills, set.skills);
        let t2 = back
            .score_table(&x, &[0, n, 2 * n], 0, EndState::Any, None)
            .unwrap();
        assert!((t2.total(0, 2, 1) - table.total(0, 2, 1)).abs() < 1e-9);
    }

    #[test]
    fn version_and_unknown_skill_are_format_errors() {
        let set = TemplateSet::train(&skills(), &features(), &examples(), &small()).unwrap();
        let json = set.to_json().unwrap();
        let v9 = json.replacen("\"format_version\":1", "\"format_version\":9", 1);
        let err = TemplateSet::from_json(&v9).unwrap_err();
        assert!(
            matches!(&err, EngineError::Format(m) if m.contains("format_version 9")),
            "{err}"
        );
        let fly = json.replacen("\"pick_up\"", "\"fly\"", 1);
        let err = TemplateSet::from_json(&fly).unwrap_err();
        assert!(
            matches!(&err, EngineError::Format(m) if m.contains("fly")),
            "{err}"
        );
        assert!(matches!(
            TemplateSet::from_json("[1,"),
            Err(EngineError::Format(_))
        ));
    }

    #[test]
    fn bad_template_contents_are_format_errors() {
        let set = TemplateSet::train(&skills(), &features(), &examples(), &small()).unwrap();
        let doc: serde_json::Value = serde_json::from_str(&set.to_json().unwrap()).unwrap();
        let refused = |edit: &dyn Fn(&mut serde_json::Value), needle: &str| {
            let mut d = doc.clone();
            edit(&mut d);
            let err = TemplateSet::from_json(&d.to_string()).unwrap_err();
            assert!(
                matches!(&err, EngineError::Format(m) if m.contains(needle)),
                "{needle}: {err}"
            );
        };
        refused(
            &|d| d["ranges"][0] = serde_json::json!([1.0, 0.0]),
            "inverted",
        );
        refused(&|d| d["ranges"][1] = serde_json::json!([0.5, 0.5]), "empty");
        refused(
            &|d| d["ranges"][2] = serde_json::json!([0.0, "inf"]),
            "ranges[2][1]: invalid type",
        );
        refused(
            &|d| d["skills"] = serde_json::json!(7),
            "skills: invalid type",
        );
        refused(&|d| d["ranges"][2] = serde_json::json!([0.0, null]), "");
        refused(&|d| d["ranges"] = serde_json::json!([[0, 1]]), "1 ranges");
        refused(
            &|d| d["n_examples"] = serde_json::json!([4]),
            "example counts",
        );
        refused(
            &|d| d["n_examples"] = serde_json::json!([4, 0]),
            "no training examples",
        );
        refused(
            &|d| d["features"][0]["end"] = serde_json::json!(0),
            "no columns",
        );
        refused(
            &|d| d["features"][1]["name"] = serde_json::json!("a"),
            "twice",
        );
        refused(&|d| d["features"] = serde_json::json!([]), "");
        refused(
            &|d| d["params"]["fit"]["n_states"] = serde_json::json!(0),
            "n_states",
        );
        refused(
            &|d| d["params"]["range_percentiles"] = serde_json::json!([99, 1]),
            "range_percentiles",
        );
        refused(
            &|d| d["params"]["fit"]["bogus"] = serde_json::json!(1),
            "bogus",
        );
        refused(&|d| d["surprise"] = serde_json::json!(1), "surprise");
        refused(
            &|d| d["skills"] = serde_json::json!(["move", "move"]),
            "twice",
        );
        // the untouched document still reads
        assert!(TemplateSet::from_json(&doc.to_string()).is_ok());
    }

    #[test]
    fn parameter_overrides_are_checked() {
        let p =
            TemplateParams::with_overrides(r#"{"fit": {"n_states": 6}, "align": false}"#).unwrap();
        assert_eq!(p.fit.n_states, 6);
        assert_eq!(p.fit.n_mix, TemplateParams::default().fit.n_mix);
        assert!(!p.align);
        assert_eq!(
            TemplateParams::with_overrides("{}").unwrap(),
            TemplateParams::default()
        );
        let refused = |json: &str, needle: &str| {
            let err = TemplateParams::with_overrides(json).unwrap_err();
            assert!(
                matches!(&err, EngineError::InvalidParameter(m) if m.contains(needle)),
                "{json}: {err}"
            );
        };
        refused(r#"{"fit": {"n_states": 0}}"#, "n_states must be >= 1");
        refused(r#"{"fit": {"n_states": -1}}"#, "fit.n_states");
        refused(r#"{"fit": {"n_states": "4"}}"#, "fit.n_states");
        refused(r#"{"fit": {"n_mix": 0}}"#, "n_mix");
        refused(
            r#"{"fit": {"n_states": 3000}}"#,
            "fit: n_states must be at most 64, got 3000",
        );
        refused(
            r#"{"fit": {"n_mix": 1000000}}"#,
            "fit: n_mix must be at most 16, got 1000000",
        );
        refused(r#"{"fit": {"covariance_floor": -1}}"#, "covariance_floor");
        refused(r#"{"fit": {"tol": 1e999}}"#, "");
        refused(r#"{"fit": {"topology": "ring"}}"#, "fit.topology");
        refused(
            r#"{"fit": {"nstates": 3}}"#,
            "unknown template parameter `fit.nstates`",
        );
        refused(r#"{"fitt": {}}"#, "unknown template parameter `fitt`");
        refused(r#"{"fit": 3}"#, "`fit` must be a JSON object");
        refused(r#"{"align": "yes"}"#, "`align`");
        refused(r#"{"dtw_band": 0}"#, "dtw_band");
        refused(r#"{"range_percentiles": [50, 50]}"#, "range_percentiles");
        refused(r#"{"range_percentiles": [-1, 50]}"#, "range_percentiles");
        refused("[1]", "JSON object");
        refused("{", "not valid JSON");
        // training checks the parameters too, instead of clamping them
        let mut zero = small();
        zero.fit.n_states = 0;
        assert!(matches!(
            TemplateSet::train(&skills(), &features(), &examples(), &zero),
            Err(EngineError::InvalidParameter(_))
        ));
    }

    #[test]
    fn normalise_clips_to_unit_interval() {
        let x = DMatrix::from_row_slice(3, 2, &[-1.0, 5.0, 0.5, 5.0, 2.0, 5.0]);
        let y = normalise(&x, &[[0.0, 1.0], [5.0, 5.0]]).unwrap();
        assert_eq!(
            y.column(0).iter().copied().collect::<Vec<_>>(),
            vec![0.0, 0.5, 1.0]
        );
        assert!(y.column(1).iter().all(|v| (v - 0.5).abs() < 1e-15));
        assert!(normalise(&x, &[[0.0, 1.0]]).is_err());
    }

    #[test]
    fn training_rejects_bad_examples() {
        let mut ex = examples();
        ex[0].1[(0, 0)] = f64::NAN;
        assert!(matches!(
            TemplateSet::train(&skills(), &features(), &ex, &small()),
            Err(EngineError::NonFinite(_))
        ));
        let only_first: Vec<_> = examples().into_iter().filter(|(s, _)| *s == 0).collect();
        assert!(matches!(
            TemplateSet::train(&skills(), &features(), &only_first, &small()),
            Err(EngineError::EmptySequence(_))
        ));
        assert!(matches!(
            TemplateSet::train(&["jump".to_string()], &features(), &examples(), &small()),
            Err(EngineError::Format(_))
        ));
    }
}
