// A law that names a parameter the model does not declare.
bondgraph_macros::bond_graph! {
    model rc
    param R1 = 2
    input I0
    Sf src = I0
    R res = R2
    src -> 0:n -> res
}

fn main() {}
