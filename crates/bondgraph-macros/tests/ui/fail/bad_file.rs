// A model file with an error: the message names the file, line and column.
bondgraph_macros::bond_graph!("tests/ui/bad_model.bg");

fn main() {}
