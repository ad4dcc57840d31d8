// A residual set that does not exist.
bondgraph::bond_graph!("../../models/dc_motor.bg", residuals = most);

fn main() {}
