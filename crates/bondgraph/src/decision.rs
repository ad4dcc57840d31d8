//! Which components a pattern of alarms points to.

use crate::prelude::*;

use crate::signature::{raised, Signature};

/// One row of the fault signature matrix, as generated code holds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Component {
    /// Its name in the model.
    pub name: &'static str,
    /// Its kind: `R`, `MSe`, `Df`, `let`…
    pub kind: &'static str,
    /// The residuals sensitive to a fault of it.
    pub signature: Signature<'static>,
    /// Some residual is sensitive to it (`Db`).
    pub detectable: bool,
    /// Detectable, with a signature no other component has (`Ib`).
    pub isolable: bool,
}

/// A fault signature matrix: residual names and components.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fsm {
    /// The residuals' names, in the order of the signatures.
    pub residuals: &'static [&'static str],
    /// The rows.
    pub components: &'static [Component],
}

impl Fsm {
    /// The components whose fault explains `alarms` (one flag per residual), under the usual
    /// single-fault assumption: those whose signature equals the alarms exactly; if none
    /// does (a fault still developing, or two at once), those whose signature holds every
    /// alarm. No alarm, no candidate.
    #[must_use]
    pub fn candidates(&self, alarms: &[bool]) -> Vec<&'static str> {
        candidates(self.rows(), alarms)
    }

    /// Each component's name and signature: the rows [`crate::Episode::rank`] and
    /// [`crate::Episode::candidates`] take.
    pub fn rows(&self) -> impl Iterator<Item = (&'static str, Signature<'static>)> + Clone {
        self.components.iter().map(|c| (c.name, c.signature))
    }

    /// The components whose fault is consistent with `alarms` without assuming that a fault
    /// fires every residual it is sensitive to (no exoneration): those whose signature holds
    /// every alarm. Wider than [`Fsm::candidates`], and it always holds the faulty component
    /// when a fault is still too small to reach some of its residuals. No alarm, no suspect.
    #[must_use]
    pub fn suspects(&self, alarms: &[bool]) -> Vec<&'static str> {
        suspects(self.rows(), alarms)
    }
}

/// [`Fsm::candidates`] over any rows `(name, signature)`: the names whose signature equals
/// `alarms`, or else those whose signature holds every alarm; none without an alarm.
pub fn candidates<'a, I>(rows: I, alarms: &[bool]) -> Vec<&'a str>
where
    I: IntoIterator<Item = (&'a str, Signature<'a>)>,
    I::IntoIter: Clone,
{
    let on = raised(alarms);
    if on.is_empty() {
        return Vec::new();
    }
    let rows = rows.into_iter();
    let exact: Vec<&'a str> = rows
        .clone()
        .filter(|(_, signature)| {
            signature.residuals() == alarms.len() && signature.marks().eq(on.iter().copied())
        })
        .map(|(name, _)| name)
        .collect();
    if !exact.is_empty() {
        return exact;
    }
    suspects(rows, alarms)
}

/// [`Fsm::suspects`] over any rows `(name, signature)`: the names whose signature holds every
/// alarm; none without an alarm.
pub fn suspects<'a, I>(rows: I, alarms: &[bool]) -> Vec<&'a str>
where
    I: IntoIterator<Item = (&'a str, Signature<'a>)>,
{
    let on = raised(alarms);
    if on.is_empty() {
        return Vec::new();
    }
    rows.into_iter()
        .filter(|(_, signature)| {
            signature.residuals() == alarms.len() && on.iter().all(|&k| signature.contains(k))
        })
        .map(|(name, _)| name)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const FSM: Fsm = Fsm {
        residuals: &["r1", "r2"],
        components: &[
            Component {
                name: "a",
                kind: "R",
                signature: Signature::new(2, &[0]),
                detectable: true,
                isolable: true,
            },
            Component {
                name: "b",
                kind: "C",
                signature: Signature::new(2, &[0, 1]),
                detectable: true,
                isolable: false,
            },
            Component {
                name: "c",
                kind: "I",
                signature: Signature::new(2, &[0, 1]),
                detectable: true,
                isolable: false,
            },
        ],
    };

    #[test]
    fn candidates_match_the_alarms_exactly_else_cover_them() {
        assert_eq!(FSM.candidates(&[false, false]), Vec::<&str>::new());
        assert_eq!(FSM.candidates(&[true, false]), ["a"]);
        assert_eq!(FSM.candidates(&[true, true]), ["b", "c"]);
        assert_eq!(FSM.candidates(&[false, true]), ["b", "c"]);
    }

    #[test]
    fn suspects_are_every_signature_that_holds_the_alarms() {
        assert_eq!(FSM.suspects(&[false, false]), Vec::<&str>::new());
        // `a` matches exactly, but a fault of `b` or `c` too small to reach r2 looks the same.
        assert_eq!(FSM.suspects(&[true, false]), ["a", "b", "c"]);
        assert_eq!(FSM.suspects(&[false, true]), ["b", "c"]);
        assert_eq!(FSM.suspects(&[true, true]), ["b", "c"]);
        // A signature of another length never matches.
        assert_eq!(
            suspects([("x", Signature::new(1, &[0]))], &[true, false]),
            Vec::<&str>::new()
        );
    }
}
