//! Skill templates (paper Sec. III-B.1-2): one HMM per skill x feature, trained with Baum-Welch
//! on the labelled segments of template demonstrations.
//!
//! Before training, every feature column is mapped to `[0, 1]` with a fixed range `[lo, hi]`
//! learned from the template set (robust percentiles), `clip((x - lo) / (hi - lo), 0, 1)`; the
//! same map is applied to new data at segmentation time, so a prefix of a normalised sequence is
//! the normalised prefix and prefix scores stay valid. Optionally every training sequence of a
//! skill x feature is warped by DTW onto the time axis of the medoid sequence first (the paper).
//!
//! A [`TemplateSet`] serialises to versioned JSON; reading another version or a skill the engine
//! does not know is a [`EngineError::Format`] error.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::scorer::{compiled_score_table, CompiledHmm, EndState};
use super::scores::{score_table, PrefixScorer, ScoreTable};
use crate::dtw::{align_to_reference, dtw_distance};
use crate::error::{EngineError, Result};
use crate::hmm::{FitConfig, Hmm};

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

/// How templates are trained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
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
                covariance_floor: 1e-3,
                ..FitConfig::default()
            },
            align: true,
            dtw_band: None,
            range_percentiles: [1.0, 99.0],
        }
    }
}

/// A trained template set: `models[skill][feature]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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
        if features.is_empty() {
            return Err(EngineError::EmptySequence("no features".into()));
        }
        let n_cols = features.iter().map(|f| f.end).max().unwrap_or(0);
        if let Some(f) = features.iter().find(|f| f.start >= f.end) {
            return Err(EngineError::InvalidParameter(format!(
                "feature {:?} has no columns",
                f.name
            )));
        }
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
        // fixed per-column ranges from robust percentiles of all template samples
        let [p_lo, p_hi] = params.range_percentiles;
        let ranges: Vec<[f64; 2]> = (0..n_cols)
            .map(|c| {
                let mut v: Vec<f64> = examples
                    .iter()
                    .flat_map(|(_, x)| x.column(c).iter().copied().collect::<Vec<_>>())
                    .collect();
                v.sort_by(f64::total_cmp);
                [percentile(&v, p_lo), percentile(&v, p_hi)]
            })
            .collect();
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
                let cols = features[f].columns();
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
                cfg.n_states = cfg.n_states.min(shortest).max(1);
                cfg.seed = params.fit.seed.wrapping_add((s * 1000 + f) as u64);
                Hmm::fit(&seqs, &cfg)
                    .map(|(hmm, _)| hmm)
                    .map_err(|e| match e {
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
        let set: Self = serde_json::from_str(text)
            .map_err(|e| EngineError::Format(format!("template file: {e}")))?;
        check_skills(&set.skills)?;
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
mod tests {
    use super::*;

    fn skills() -> Vec<String> {
        vec!["pick_up".into(), "move".into()]
    }

    fn features() -> Vec<FeatureGroup> {
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
    fn examples() -> Vec<(usize, DMatrix<f64>)> {
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

    fn small() -> TemplateParams {
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
