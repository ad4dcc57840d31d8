//! Which components a pattern of alarms points to.

/// One row of the fault signature matrix, as generated code holds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Component {
    /// Its name in the model.
    pub name: &'static str,
    /// Its kind: `R`, `MSe`, `Df`, `let`…
    pub kind: &'static str,
    /// Whether each residual is sensitive to a fault of it.
    pub signature: &'static [bool],
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
        candidates(
            self.components.iter().map(|c| (c.name, c.signature)),
            alarms,
        )
    }
}

/// [`Fsm::candidates`] over any rows `(name, signature)`: the names whose signature equals
/// `alarms`, or else those whose signature holds every alarm; none without an alarm.
pub fn candidates<'a, I>(rows: I, alarms: &[bool]) -> Vec<&'a str>
where
    I: IntoIterator<Item = (&'a str, &'a [bool])>,
    I::IntoIter: Clone,
{
    if !alarms.iter().any(|&a| a) {
        return Vec::new();
    }
    let rows = rows.into_iter();
    let exact: Vec<&'a str> = rows
        .clone()
        .filter(|(_, signature)| *signature == alarms)
        .map(|(name, _)| name)
        .collect();
    if !exact.is_empty() {
        return exact;
    }
    rows.filter(|(_, signature)| {
        signature.len() == alarms.len() && alarms.iter().zip(*signature).all(|(&a, &s)| !a || s)
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
                signature: &[true, false],
                detectable: true,
                isolable: true,
            },
            Component {
                name: "b",
                kind: "C",
                signature: &[true, true],
                detectable: true,
                isolable: false,
            },
            Component {
                name: "c",
                kind: "I",
                signature: &[true, true],
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
}
