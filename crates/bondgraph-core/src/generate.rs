//! Synthetic models for benchmarks and scaling tests.

use std::fmt::Write as _;

/// A chain of `stages` masses, each with a viscous damper to the ground and a spring to the
/// next mass (the last one's spring holds it to the ground), driven by a force at the first
/// mass, with a velocity detector on every `detector_every`-th mass (none when it is 0).
/// Each stage has 3 elements (I, R, C) and 2 junctions (the mass velocity and the spring
/// force), the last stage 1. All stages share the parameters `m`, `k` and `d`.
pub fn mass_spring_chain(stages: usize, detector_every: usize) -> String {
    chain(stages, detector_every, Parameters::Shared)
}

/// The same chain with parameters of its own at each stage (`M3`, `K3`, `D3`), all
/// different, so that a fault in one stage is a change of one parameter.
pub fn mass_spring_chain_varied(stages: usize, detector_every: usize) -> String {
    chain(stages, detector_every, Parameters::PerStage)
}

/// Whether the stages of a generated chain share their parameters.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Parameters {
    Shared,
    PerStage,
}

fn chain(stages: usize, detector_every: usize, parameters: Parameters) -> String {
    let mut out = String::with_capacity(stages * 120);
    let _ = writeln!(out, "model chain_{stages}\n");
    if parameters == Parameters::Shared {
        let _ = writeln!(
            out,
            "param m = 1 [kg]\nparam k = 100 [N/m]\nparam d = 0.5 [N.s/m]"
        );
    }
    let _ = writeln!(out, "input F [N]\n\nSe force = F");
    for i in 0..stages {
        let (m, k, d) = match parameters {
            Parameters::Shared => ("m".to_string(), "k".to_string(), "d".to_string()),
            Parameters::PerStage => {
                // Values that differ between stages and keep every mode slow, so that the
                // high derivatives a local ARR needs stay of moderate size.
                let f = (i % 7) as f64;
                let _ = writeln!(
                    out,
                    "param M{i} = {} [kg]\nparam K{i} = {} [N/m]\nparam D{i} = {} [N.s/m]",
                    1.0 + 0.1 * f,
                    0.3 + 0.05 * f,
                    0.2 + 0.03 * f
                );
                (format!("M{i}"), format!("K{i}"), format!("D{i}"))
            }
        };
        let _ = writeln!(out, "I m{i} = {m}\nR d{i} = {d}\nC k{i} stiffness {k}");
    }
    let _ = writeln!(out);
    let _ = writeln!(out, "force -> 1:v0");
    for i in 0..stages {
        let _ = writeln!(out, "v{i} -> m{i}, d{i}");
        if i + 1 < stages {
            let _ = writeln!(out, "v{i} -> 0:s{i} -> k{i}");
            let _ = writeln!(out, "s{i} -> 1:v{}", i + 1);
        } else {
            let _ = writeln!(out, "v{i} -> k{i}");
        }
        if detector_every > 0 && i % detector_every == 0 {
            let _ = writeln!(out, "Df y{i} on v{i}");
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_chains_are_valid_and_sized_as_documented() {
        for (stages, text) in [1, 2, 7].into_iter().flat_map(|n| {
            [
                (n, mass_spring_chain(n, 5)),
                (n, mass_spring_chain_varied(n, 5)),
            ]
        }) {
            let (graph, diagnostics) = crate::graph::load(&text);
            let graph = graph.unwrap_or_else(|| panic!("{diagnostics:#?}"));
            let counts = graph.counts();
            assert_eq!(counts.elements, 3 * stages + 1);
            assert_eq!(counts.junctions, 2 * stages - 1);
            assert_eq!(counts.detectors, stages.div_ceil(5));
        }
    }
}
