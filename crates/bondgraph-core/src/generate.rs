//! Synthetic models for benchmarks and scaling tests.

use std::fmt::Write as _;

/// A chain of `stages` masses, each tied to the next by a spring and a damper, driven by a
/// force at the first mass, with a velocity detector on every `detector_every`-th mass
/// (none when `detector_every` is 0). Each stage has 3 elements (I, C, R) and, but the last,
/// 3 junctions: the mass velocity, the link force and the link's relative velocity.
pub fn mass_spring_chain(stages: usize, detector_every: usize) -> String {
    let mut out = String::with_capacity(stages * 160);
    let _ = writeln!(out, "model chain_{stages}\n");
    let _ = writeln!(
        out,
        "param m = 1 [kg]\nparam k = 100 [N/m]\nparam d = 0.5 [N.s/m]"
    );
    let _ = writeln!(out, "input F [N]\n\nSe force = F");
    for i in 0..stages {
        let _ = writeln!(out, "I m{i} = m\nC k{i} = 1 / k\nR d{i} = d");
    }
    let _ = writeln!(out);
    let _ = writeln!(out, "force -> 1:v0");
    for i in 0..stages {
        let _ = writeln!(out, "v{i} -> m{i}");
        if i + 1 < stages {
            let _ = writeln!(out, "v{i} -> 0:s{i} -> 1:w{i} -> d{i}");
            let _ = writeln!(out, "w{i} -> k{i}");
            let _ = writeln!(out, "s{i} -> 1:v{}", i + 1);
        } else {
            // The last spring and damper hold the chain to the ground.
            let _ = writeln!(out, "v{i} -> d{i}, k{i}");
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
        for stages in [1, 2, 7] {
            let (graph, diagnostics) = crate::load(&mass_spring_chain(stages, 5));
            let graph = graph.unwrap_or_else(|| panic!("{diagnostics:#?}"));
            let counts = graph.counts();
            assert_eq!(counts.elements, 3 * stages + 1);
            assert_eq!(counts.junctions, 3 * stages - 2);
            assert_eq!(counts.detectors, stages.div_ceil(5));
        }
    }
}
