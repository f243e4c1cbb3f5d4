//! The skill semantic ordering (paper Fig. 6) as data: which skill may start a demonstration and
//! which skill may follow which.
//!
//! The grammar is read from JSON (the file shipped as `lfd/data/grammar.json`) and bound to the
//! skill order of a template set with [`Grammar::for_skills`], which turns names into indices.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::templates::KNOWN_SKILLS;
use crate::error::{EngineError, Result};

/// Format version of the grammar JSON this engine reads.
pub const GRAMMAR_FORMAT_VERSION: u32 = 1;

/// The grammar as written in the JSON file: names, not indices.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct GrammarSpec {
    /// Must equal [`GRAMMAR_FORMAT_VERSION`].
    pub format_version: u32,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Named groups of skills (e.g. `holding`, `not_holding`); informative only.
    #[serde(default)]
    pub groups: BTreeMap<String, Vec<String>>,
    /// Skills that may start a demonstration.
    pub start: Vec<String>,
    /// `transitions[a]` lists the skills that may follow `a`.
    pub transitions: BTreeMap<String, Vec<String>>,
    /// Skills whose TCP rises (the Fig. 5 decision tree); all others have a constant or
    /// decreasing TCP.
    pub rising: Vec<String>,
}

impl GrammarSpec {
    /// Parse a grammar from JSON text.
    pub fn from_json(text: &str) -> Result<Self> {
        let spec: GrammarSpec = serde_json::from_str(text)
            .map_err(|e| EngineError::Format(format!("grammar JSON: {e}")))?;
        if spec.format_version != GRAMMAR_FORMAT_VERSION {
            return Err(EngineError::Format(format!(
                "grammar format_version {} is not supported (this engine reads version {})",
                spec.format_version, GRAMMAR_FORMAT_VERSION
            )));
        }
        Ok(spec)
    }
}

/// A grammar bound to an ordered list of skills (indices as in a template set).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Grammar {
    skills: Vec<String>,
    start: Vec<bool>,
    /// Row-major `n x n`: `allowed[a * n + b]` = skill `b` may follow skill `a`.
    allowed: Vec<bool>,
    rising: Vec<bool>,
}

impl Grammar {
    /// Bind `spec` to `skills`. A name in the spec that is one of the engine's skills
    /// ([`KNOWN_SKILLS`]) but not in `skills` (a template set trained on fewer skills) is left
    /// out; any other name is a [`EngineError::Format`] naming the unknown skill.
    pub fn for_skills(spec: &GrammarSpec, skills: &[String]) -> Result<Self> {
        let n = skills.len();
        if n == 0 {
            return Err(EngineError::EmptySequence(
                "grammar needs at least one skill".into(),
            ));
        }
        let index = |name: &str| -> Result<Option<usize>> {
            if let Some(i) = skills.iter().position(|s| s == name) {
                return Ok(Some(i));
            }
            if KNOWN_SKILLS.contains(&name) {
                return Ok(None);
            }
            Err(EngineError::Format(format!(
                "grammar names unknown skill {name:?} (skills: {})",
                skills.join(", ")
            )))
        };
        let mut start = vec![false; n];
        for s in &spec.start {
            if let Some(i) = index(s)? {
                start[i] = true;
            }
        }
        let mut allowed = vec![false; n * n];
        for (from, tos) in &spec.transitions {
            let a = index(from)?;
            for to in tos {
                if let (Some(a), Some(b)) = (a, index(to)?) {
                    allowed[a * n + b] = true;
                }
            }
        }
        let mut rising = vec![false; n];
        for s in &spec.rising {
            if let Some(i) = index(s)? {
                rising[i] = true;
            }
        }
        for group in spec.groups.values() {
            for s in group {
                index(s)?;
            }
        }
        Ok(Self {
            skills: skills.to_vec(),
            start,
            allowed,
            rising,
        })
    }

    /// A grammar that allows everything (no skill is "rising"-restricted either).
    pub fn permissive(skills: &[String]) -> Self {
        let n = skills.len();
        Self {
            skills: skills.to_vec(),
            start: vec![true; n],
            allowed: vec![true; n * n],
            rising: vec![false; n],
        }
    }

    /// Number of skills.
    pub fn n_skills(&self) -> usize {
        self.skills.len()
    }

    /// Skill names in index order.
    pub fn skills(&self) -> &[String] {
        &self.skills
    }

    /// May skill `next` follow `prev` (`None` = start of the demonstration)?
    pub fn allows(&self, prev: Option<usize>, next: usize) -> bool {
        let n = self.skills.len();
        if next >= n {
            return false;
        }
        match prev {
            None => self.start[next],
            Some(p) if p < n => self.allowed[p * n + next],
            Some(_) => false,
        }
    }

    /// Is `skill` one of the rising-TCP skills (Move, Move with)?
    pub fn is_rising(&self, skill: usize) -> bool {
        self.rising.get(skill).copied().unwrap_or(false)
    }

    /// Human-readable name of a transition, for warnings.
    pub fn describe(&self, prev: Option<usize>, next: usize) -> String {
        let name = |i: usize| self.skills.get(i).map_or("?", String::as_str);
        match prev {
            None => format!("start -> {}", name(next)),
            Some(p) => format!("{} -> {}", name(p), name(next)),
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) const PAPER_GRAMMAR: &str = r#"{
      "format_version": 1,
      "groups": {"holding": ["move_with", "place", "stack"],
                 "not_holding": ["pick_up", "push", "locate", "move"]},
      "start": ["pick_up", "push", "locate", "move"],
      "transitions": {
        "pick_up": ["move_with"], "move_with": ["place", "stack"], "place": ["move"],
        "stack": ["move"], "move": ["pick_up", "push", "locate"], "push": ["move"],
        "locate": ["move", "pick_up", "push"]
      },
      "rising": ["move", "move_with"]
    }"#;

    pub(crate) fn paper_skills() -> Vec<String> {
        KNOWN_SKILLS.iter().map(ToString::to_string).collect()
    }

    pub(crate) fn paper_grammar() -> Grammar {
        Grammar::for_skills(
            &GrammarSpec::from_json(PAPER_GRAMMAR).unwrap(),
            &paper_skills(),
        )
        .unwrap()
    }

    #[test]
    fn paper_transitions() {
        let g = paper_grammar();
        let ix = |s: &str| paper_skills().iter().position(|x| x == s).unwrap();
        assert!(g.allows(None, ix("pick_up")));
        assert!(!g.allows(None, ix("place")));
        assert!(g.allows(Some(ix("pick_up")), ix("move_with")));
        assert!(!g.allows(Some(ix("pick_up")), ix("move")));
        assert!(!g.allows(Some(ix("place")), ix("place")));
        assert!(g.allows(Some(ix("locate")), ix("push")));
        assert!(g.is_rising(ix("move")) && g.is_rising(ix("move_with")));
        assert!(!g.is_rising(ix("push")));
        assert_eq!(g.describe(Some(ix("place")), ix("stack")), "place -> stack");
    }

    #[test]
    fn unknown_skill_and_version_are_format_errors() {
        let bad = PAPER_GRAMMAR.replace("\"locate\", \"move\"]", "\"locate\", \"fly\"]");
        let spec = GrammarSpec::from_json(&bad).unwrap();
        let err = Grammar::for_skills(&spec, &paper_skills()).unwrap_err();
        assert!(matches!(err, EngineError::Format(m) if m.contains("fly")));
        let v2 = PAPER_GRAMMAR.replace("\"format_version\": 1", "\"format_version\": 2");
        assert!(matches!(
            GrammarSpec::from_json(&v2),
            Err(EngineError::Format(_))
        ));
        assert!(matches!(
            GrammarSpec::from_json("{"),
            Err(EngineError::Format(_))
        ));
    }
}
