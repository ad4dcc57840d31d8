// A model file commented with `//`, whose law names a parameter it does not declare: the
// comments are read as comments, and the error shows the line and what was expected.
bondgraph_macros::bond_graph!("tests/ui/slash_comments.bg");

fn main() {}
