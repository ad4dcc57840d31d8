// A statement that is not one.
bondgraph::bond_graph! {
    model rc
    param R1 = = 2
}

fn main() {}
