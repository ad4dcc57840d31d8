// A path to a model that is not there.
bondgraph::bond_graph!("models/missing.bg");

fn main() {}
