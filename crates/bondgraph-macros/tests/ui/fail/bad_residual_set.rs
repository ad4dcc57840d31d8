// A residual set that does not exist.
bondgraph_macros::bond_graph!("../../models/dc_motor.bg", residuals = most);

fn main() {}
