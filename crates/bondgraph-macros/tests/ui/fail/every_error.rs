// Two mistakes in one inline model: each is an error at its own token, with the help.
bondgraph_macros::bond_graph! {
    model rc
    param R1 = 2
    param C1 = 1
    input I0
    Sf src = I0
    R res = R2
    C cap = Cl
    De v on n
    src -> 0:n -> res, cap
}

fn main() {}
