// A realisation the macro does not know.
bondgraph::bond_graph!("../../models/dc_motor.bg", realise = integral);

fn main() {}
