// A path to a model that is not there.
bondgraph_macros::bond_graph!("models/missing.bg");

fn main() {}
