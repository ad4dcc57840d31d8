//! How leaves of expressions are named in each output.

use bondgraph_core::{Compiled, Handle, LoopUnknown, Symbol};

/// `name`, `der(name)` or `der(name, n)`.
fn derivative(name: &str, n: u32) -> String {
    match n {
        0 => name.to_string(),
        1 => format!("der({name})"),
        n => format!("der({name}, {n})"),
    }
}

/// The name of an algebraic loop's unknown (only state equations, which hold the loops,
/// read one).
fn loop_name(c: &Compiled, k: Handle<LoopUnknown>) -> String {
    c.state_space
        .as_ref()
        .and_then(|s| s.loops.get(k.index()))
        .map_or_else(String::new, |l| l.name.clone())
}

/// The plain-text name of a leaf: `Re`, `U0`, `der(y1)`, `der(y1, 2)`, `t`, `p_Lm`.
pub(crate) fn text(c: &Compiled, symbol: Symbol) -> String {
    match symbol {
        Symbol::Parameter(p) => c.parameters[p].name.clone(),
        Symbol::Input(u, n) => derivative(&c.inputs[u].name, n),
        Symbol::Sensor(s, n) => derivative(&c.sensors[s].name, n),
        Symbol::Auxiliary(a, n) => derivative(&c.auxiliaries[a].name, n),
        Symbol::State(k) => c.states[k].name.clone(),
        Symbol::Time => "t".to_string(),
        Symbol::Loop(k) => loop_name(c, k),
        Symbol::Root(k, n) => derivative(&c.roots[k].name, n),
    }
}

const GREEK: [&str; 24] = [
    "alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa",
    "lambda", "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi",
    "omega", "Omega",
];

/// A name in LaTeX: `gamma` → `\gamma`, `y1` → `y_{1}`, `theta_e` → `\theta_{e}`; other
/// multi-letter names stay upright words (`\mathrm{Re}`), since `Re` is not `R·e`.
pub(crate) fn latex_name(name: &str) -> String {
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
pub(crate) fn latex_derivative(name: &str, n: u32) -> String {
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
pub(crate) fn latex(c: &Compiled, symbol: Symbol) -> String {
    match symbol {
        Symbol::Parameter(p) => latex_name(&c.parameters[p].name),
        Symbol::Input(u, n) => latex_derivative(&c.inputs[u].name, n),
        Symbol::Sensor(s, n) => latex_derivative(&c.sensors[s].name, n),
        Symbol::Auxiliary(a, n) => latex_derivative(&c.auxiliaries[a].name, n),
        Symbol::State(k) => latex_name(&c.states[k].name),
        Symbol::Time => "t".to_string(),
        Symbol::Loop(k) => latex_name(&loop_name(c, k)),
        Symbol::Root(k, n) => latex_derivative(&c.roots[k].name, n),
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
