//! `cobalt`: the command line of the cobalt workspace.
fn main() {}
