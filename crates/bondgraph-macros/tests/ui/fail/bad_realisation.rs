// A realisation the macro does not know.
bondgraph_macros::bond_graph!("../../models/dc_motor.bg", realise = integral);

fn main() {}
