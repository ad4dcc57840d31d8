//! A bank's relations alone: what fits and sizes read where simulated residuals sit beside
//! the ARRs.
//!
//! A simulated residual runs a copy of the model at every evaluation of a fit (its Jacobian
//! runs it once more per parameter), which on the bench's 300-s record took minutes where
//! the relations take seconds; and the output error it fits weighs the model's dynamics
//! differently from the relations, so that the bank's relations, at the values a joint fit
//! found, were an order of magnitude noisier than at their own (ARR1's RMS 7.5e-3 against
//! 3.6e-4 on the healthy record). The relations fit the parameters, and the copies run with
//! the values they find.

use bondgraph_core::program::Program;
use bondgraph_core::Compiled;

/// The relations of a model that carries simulated residuals beside them, with their
/// program and where each of its raw signals is among the whole program's.
pub struct Relations {
    /// The model with its relations alone (see [`Compiled::relations`]).
    pub compiled: Compiled,
    /// Their residual program.
    pub program: Program,
    /// For each raw signal of [`Relations::program`], its place among the whole program's.
    places: Vec<usize>,
}

impl Relations {
    /// The relations of `c` (whose program is `program`), where it carries simulated
    /// residuals beside them; `None` where it does not, or where a signal the relations
    /// read is not among the program's (which would be a bug, kept from a panic).
    pub fn of(c: &Compiled, program: &Program) -> Option<Relations> {
        let compiled = c.relations()?;
        let own = compiled.program();
        let places = (own.raw.values())
            .map(|r| program.raw.values().position(|w| w.name == r.name))
            .collect::<Option<Vec<usize>>>()?;
        Some(Relations {
            compiled,
            program: own,
            places,
        })
    }

    /// The relations' raw columns out of the whole program's `columns`.
    pub fn columns<'a>(&self, columns: &[&'a [f64]]) -> Vec<&'a [f64]> {
        self.places.iter().map(|&k| columns[k]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bondgraph_core::{compile, Options, ResidualSet};

    /// The bench's bank: its two relations alone, their signals found among the bank's;
    /// the relations alone have none to leave out.
    #[test]
    fn the_benchs_bank_has_its_relations_and_the_relations_alone_none() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/backlash_bench.bg"
        ))
        .unwrap();
        let options = Options {
            residuals: ResidualSet::Bank,
            ..Options::default()
        };
        let bank = compile(&text, "backlash_bench.bg", &options)
            .expect("compiles")
            .compiled;
        assert_eq!(bank.arrs.len(), 4);
        let program = bank.program();
        let relations = Relations::of(&bank, &program).unwrap();
        assert_eq!(relations.compiled.arrs.len(), 2);
        assert!(relations.program.copy.is_none());
        let columns: Vec<Vec<f64>> = (0..program.raw.len()).map(|k| vec![k as f64]).collect();
        let all: Vec<&[f64]> = columns.iter().map(Vec::as_slice).collect();
        let names: Vec<&str> = program.raw.values().map(|r| r.name.as_str()).collect();
        for (r, column) in relations.program.raw.values().zip(relations.columns(&all)) {
            assert_eq!(names[column[0] as usize], r.name);
        }
        assert!(Relations::of(&relations.compiled, &relations.program).is_none());
    }
}
