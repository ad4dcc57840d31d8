//! How leaves of expressions are named in each output.

use bondgraph_core::graph::BondGraph;
use bondgraph_core::sim::StateEquation;
use bondgraph_core::symbolic::Leaf;

/// The plain-text name of a leaf: `Re`, `U0`, `der(y1)`, `der(y1, 2)`, `t`, `p_Lm`.
pub fn text(model: &BondGraph, states: &[StateEquation], leaf: Leaf) -> String {
    let derivative = |name: &str, n: u32| match n {
        0 => name.to_string(),
        1 => format!("der({name})"),
        n => format!("der({name}, {n})"),
    };
    match leaf {
        Leaf::Param(p) => model.params[p.0 as usize].name.clone(),
        Leaf::Input(u, n) => derivative(&model.inputs[u.0 as usize].name, n),
        Leaf::Sensor(s, n) => derivative(&model.node(s).name, n),
        Leaf::State(k) => states
            .get(k as usize)
            .map_or_else(|| format!("x{k}"), |s| s.name.clone()),
        Leaf::Time => "t".to_string(),
        Leaf::Var(v) => format!("unknown{v}"),
        Leaf::Tear(v, n) => derivative(&format!("unknown{v}"), n),
    }
}

const GREEK: [&str; 24] = [
    "alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa",
    "lambda", "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi",
    "omega", "Omega",
];

/// A name in LaTeX: `gamma` → `\gamma`, `y1` → `y_{1}`, `theta_e` → `\theta_{e}`; other
/// multi-letter names stay upright words (`\mathrm{Re}`), since `Re` is not `R·e`.
pub fn latex_name(name: &str) -> String {
    let (stem, sub) = match name.split_once('_') {
        Some((stem, sub)) => (stem.to_string(), Some(sub.to_string())),
        None => {
            let digits = name.len() - name.trim_end_matches(|c: char| c.is_ascii_digit()).len();
            if digits > 0 && digits < name.len() {
                let (s, d) = name.split_at(name.len() - digits);
                (s.to_string(), Some(d.to_string()))
            } else {
                (name.to_string(), None)
            }
        }
    };
    let stem = if GREEK.contains(&stem.as_str()) {
        format!("\\{stem}")
    } else if stem.chars().count() > 1 {
        format!("\\mathrm{{{}}}", stem.replace('_', "\\_"))
    } else {
        stem
    };
    match sub {
        Some(sub) => format!("{stem}_{{{}}}", sub.replace('_', "\\_")),
        None => stem,
    }
}

/// The n-th time derivative of a named signal: `\dot{y}_{1}`, `\ddot{y}_{1}`, `{y_{1}}^{(3)}`.
pub fn latex_derivative(name: &str, n: u32) -> String {
    {
        let base = latex_name(name);
        match n {
            0 => base,
            1 | 2 => {
                let accent = if n == 1 { "\\dot" } else { "\\ddot" };
                // Put the accent on the stem, keep the subscript outside.
                match base.split_once('_') {
                    Some((stem, sub)) => format!("{accent}{{{stem}}}_{sub}"),
                    None => format!("{accent}{{{base}}}"),
                }
            }
            n => format!("{{{base}}}^{{({n})}}"),
        }
    }
}

/// The LaTeX name of a leaf.
pub fn latex(model: &BondGraph, states: &[StateEquation], leaf: Leaf) -> String {
    match leaf {
        Leaf::Param(p) => latex_name(&model.params[p.0 as usize].name),
        Leaf::Input(u, n) => latex_derivative(&model.inputs[u.0 as usize].name, n),
        Leaf::Sensor(s, n) => latex_derivative(&model.node(s).name, n),
        Leaf::State(_) => latex_name(&text(model, states, leaf)),
        Leaf::Time => "t".to_string(),
        Leaf::Var(v) => format!("u_{{{v}}}"),
        Leaf::Tear(v, n) => latex_derivative(&format!("u{v}"), n),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latex_names_follow_the_usual_conventions() {
        assert_eq!(latex_name("gamma"), "\\gamma");
        assert_eq!(latex_name("y1"), "y_{1}");
        assert_eq!(latex_name("theta_e"), "\\theta_{e}");
        assert_eq!(latex_name("Re"), "\\mathrm{Re}");
        assert_eq!(latex_name("K"), "K");
        assert_eq!(latex_name("p_Lm"), "p_{Lm}");
    }
}
