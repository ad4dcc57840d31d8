//! The two namespaces of a model and the "did you mean" that goes with an unknown name.
//!
//! Signals (parameters, inputs, `let`s, detectors, `t`) are what expressions use; nodes
//! (elements, junctions, detectors) are what bonds join. A detector lives in both: its name is
//! the measured signal. An element may share a name with a parameter (`I L = L` is common).

use std::collections::{HashMap, HashSet};

use super::model::{InputId, LetId, NodeId, ParamId};
use crate::diagnostic::Span;

/// What a signal name was declared as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SignalSlot {
    Param(ParamId),
    Input(InputId),
    Let(LetId),
    Sensor(NodeId),
}

/// Names declared so far, with where; plus names whose declaration failed, so that their uses
/// do not raise a second, confusing error.
#[derive(Default)]
pub(crate) struct Scope {
    signals: HashMap<String, (SignalSlot, Span)>,
    nodes: HashMap<String, (NodeId, Span)>,
    broken_signals: HashSet<String>,
    broken_nodes: HashSet<String>,
}

/// The outcome of looking a name up.
pub(crate) enum Lookup<T> {
    Found(T),
    /// Declared, but its declaration was in error: stay quiet.
    Broken,
    Missing,
}

impl Scope {
    /// Declares a signal; on a clash returns the span of the first declaration.
    pub(super) fn declare_signal(
        &mut self,
        name: &str,
        slot: SignalSlot,
        span: Span,
    ) -> Result<(), Span> {
        if let Some((_, first)) = self.signals.get(name) {
            return Err(*first);
        }
        self.signals.insert(name.to_string(), (slot, span));
        Ok(())
    }

    /// Declares a node; on a clash returns the first declaration.
    pub(super) fn declare_node(
        &mut self,
        name: &str,
        id: NodeId,
        span: Span,
    ) -> Result<(), (NodeId, Span)> {
        if let Some(first) = self.nodes.get(name) {
            return Err(*first);
        }
        self.nodes.insert(name.to_string(), (id, span));
        Ok(())
    }

    /// Marks a signal name as declared in error.
    pub(super) fn break_signal(&mut self, name: &str) {
        self.broken_signals.insert(name.to_string());
    }

    /// Marks a node name as declared in error.
    pub(super) fn break_node(&mut self, name: &str) {
        self.broken_nodes.insert(name.to_string());
    }

    /// Looks a signal up.
    pub(super) fn signal(&self, name: &str) -> Lookup<(SignalSlot, Span)> {
        match self.signals.get(name) {
            Some(found) => Lookup::Found(*found),
            None if self.broken_signals.contains(name) => Lookup::Broken,
            None => Lookup::Missing,
        }
    }

    /// Looks a node up.
    pub(super) fn node(&self, name: &str) -> Lookup<(NodeId, Span)> {
        match self.nodes.get(name) {
            Some(found) => Lookup::Found(*found),
            None if self.broken_nodes.contains(name) => Lookup::Broken,
            None => Lookup::Missing,
        }
    }

    /// The declared signal closest to `name`, if one is close enough to be a typo.
    pub(super) fn similar_signal(&self, name: &str) -> Option<&str> {
        closest(name, self.signals.keys().map(String::as_str))
    }

    /// The declared node closest to `name`, if one is close enough to be a typo.
    pub(super) fn similar_node(&self, name: &str) -> Option<&str> {
        closest(name, self.nodes.keys().map(String::as_str))
    }
}

/// Past this many candidates, suggestions are skipped: an error in a huge generated model must
/// not cost a quadratic search.
const MAX_CANDIDATES: usize = 5_000;

/// The candidate within a small edit distance of `name` (ties broken alphabetically, so the
/// suggestion does not depend on hash order): what "did you mean" names.
pub fn closest<'a>(
    name: &str,
    candidates: impl ExactSizeIterator<Item = &'a str>,
) -> Option<&'a str> {
    if candidates.len() > MAX_CANDIDATES {
        return None;
    }
    let length = name.chars().count();
    let limit = (length / 3).max(1);
    candidates
        .filter_map(|c| {
            // A name differing only in case is the likeliest slip of all.
            if c.to_lowercase() == name.to_lowercase() {
                return Some((0, c));
            }
            let d = edit_distance(name, c);
            // Replacing every letter of a short name is not a typo.
            (d <= limit && d < length).then_some((d, c))
        })
        .min()
        .map(|(_, c)| c)
}

/// Levenshtein distance in characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut previous: Vec<usize> = (0..=b.len()).collect();
    let mut current = vec![0; b.len() + 1];
    for (i, ca) in a.iter().enumerate() {
        current[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitution = usize::from(ca != cb);
            current[j + 1] = (previous[j] + substitution)
                .min(previous[j + 1] + 1)
                .min(current[j] + 1);
        }
        std::mem::swap(&mut previous, &mut current);
    }
    previous[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_near_names_only() {
        let names = ["Re", "ke", "gamma", "Js"];
        assert_eq!(closest("gama", names.into_iter()), Some("gamma"));
        assert_eq!(closest("re", names.into_iter()), Some("Re"));
        assert_eq!(closest("voltage", names.into_iter()), None);
        assert_eq!(closest("k", ["K", "j"].into_iter()), Some("K"));
        assert_eq!(closest("q", ["j"].into_iter()), None);
    }

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "ab"), 2);
        assert_eq!(edit_distance("ab", "ab"), 0);
    }
}
