//! How a fitted parameter moves: by a factor, so that a magnitude (a mass, a resistance, a
//! stiffness) keeps its sign and a parameter known to orders of magnitude is fitted on its
//! logarithm; or by a shift, so that an offset, a bias or a signed gain may cross zero.

use bondgraph_core::{Compiled, ComponentKind};

/// How one parameter's value follows the fit's coordinate `u` (0 at its start).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Scaling {
    /// `start · exp(u)`: the sign is kept.
    Factor,
    /// `start + size · u`: any real value; `size` is the start's magnitude (1 at 0), so
    /// that the fit's differences are relative to it.
    Shift(f64),
}

/// Each parameter's scaling, in the model's order, at the values `start`.
///
/// A parameter moves by a shift where it may cross zero: the model gives it a value of 0
/// or below (nothing then says it is a magnitude), or only sources read it (the value of an
/// effort or a flow a source imposes: an offset force, a bias). A parameter of an element's
/// law (`R`, `C`, `I`, `TF`, `GY`, a modulation) is a magnitude and moves by a factor.
pub(crate) fn scalings(c: &Compiled, start: &[f64]) -> Vec<Scaling> {
    let mut source = vec![false; start.len()];
    let mut law = vec![false; start.len()];
    for component in c.components.values() {
        let applied = matches!(
            component.kind,
            ComponentKind::Element("Se" | "Sf" | "MSe" | "MSf")
        );
        for p in &component.parameters {
            let k = p.index();
            if k < start.len() {
                if applied {
                    source[k] = true;
                } else {
                    law[k] = true;
                }
            }
        }
    }
    (start.iter().enumerate())
        .map(|(k, &v)| {
            if v <= 0.0 || (source[k] && !law[k]) {
                Scaling::Shift(if v == 0.0 { 1.0 } else { v.abs() })
            } else {
                Scaling::Factor
            }
        })
        .collect()
}

impl Scaling {
    /// The value at coordinate `u` from `start`.
    pub(crate) fn value(self, start: f64, u: f64) -> f64 {
        match self {
            Scaling::Factor => start * u.exp(),
            Scaling::Shift(size) => start + size * u,
        }
    }

    /// The value's rate of change with the coordinate where it is `value`: what turns the
    /// coordinate's interval into the value's.
    pub(crate) fn slope(self, value: f64) -> f64 {
        match self {
            Scaling::Factor => value.abs(),
            Scaling::Shift(size) => size,
        }
    }

    /// Whether `value` is out of all proportion to `start`: more than `factor` times it or
    /// less than its `factor`-th part for a magnitude; further from it than `factor` times
    /// its size for a shift.
    pub(crate) fn ran_away(self, start: f64, value: f64, factor: f64) -> bool {
        if !value.is_finite() {
            return true;
        }
        match self {
            Scaling::Factor => start != 0.0 && (value / start).abs().ln().abs() > factor.ln(),
            Scaling::Shift(size) => (value - start).abs() > factor * size,
        }
    }

    /// Whether it may cross zero.
    pub(crate) fn signed(self) -> bool {
        matches!(self, Scaling::Shift(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn compiled(text: &str) -> Compiled {
        let options = bondgraph_core::Options::default();
        match bondgraph_core::compile(text, "t.bg", &options) {
            Ok(out) => out.compiled,
            Err(d) => panic!("{d:?}"),
        }
    }

    #[test]
    fn an_offset_a_source_applies_may_cross_zero_and_a_mass_may_not() {
        let c = compiled(
            "model m\nparam M = 90\nparam Fv = 180\nparam offset = 2\nparam z = 0\n\
             input tau\nSe drive = tau\nSe bias = -offset\nI load = M\nR visc = Fv + z\n\
             Df v on axis\ndrive -> 1:axis -> load, visc\nbias -> axis\n",
        );
        let start: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
        let s = scalings(&c, &start);
        assert_eq!(s[0], Scaling::Factor, "M");
        assert_eq!(s[1], Scaling::Factor, "Fv");
        assert_eq!(s[2], Scaling::Shift(2.0), "offset, read by a source only");
        assert_eq!(
            s[3],
            Scaling::Shift(1.0),
            "z: 0, so nothing says it is a magnitude"
        );
        assert_eq!(Scaling::Shift(2.0).value(2.0, -2.5), -3.0);
        assert!((Scaling::Factor.value(90.0, 0.1f64.ln_1p()) - 99.0).abs() < 1e-9);
    }

    #[test]
    fn runaway_is_relative_to_the_start() {
        assert!(Scaling::Factor.ran_away(1.0, 2e-158, 1e6));
        assert!(Scaling::Factor.ran_away(1.0, 1e158, 1e6));
        assert!(!Scaling::Factor.ran_away(1.0, 3.0, 1e6));
        assert!(Scaling::Shift(2.0).ran_away(-2.0, 1e7, 1e6));
        assert!(!Scaling::Shift(2.0).ran_away(-2.0, 5.0, 1e6));
        assert!(Scaling::Shift(2.0).ran_away(-2.0, f64::NAN, 1e6));
    }
}
