// A statement that is not one.
bondgraph_macros::bond_graph! {
    model rc
    param R1 = = 2
}

fn main() {}
