//! KLT benchmark (being written).
fn main() {}
