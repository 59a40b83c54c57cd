//! The `patchvis` command-line tool.

fn main() {}
