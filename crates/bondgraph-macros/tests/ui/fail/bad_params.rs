// A parameter file naming a parameter the model does not declare: refused at its line.
bondgraph_macros::bond_graph!("../../models/dc_motor.bg", params = "tests/ui/bad.params");

fn main() {}
