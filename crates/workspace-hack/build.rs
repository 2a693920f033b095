//! A build script, so that Cargo counts this crate's [build-dependencies] (the host-side half of
//! the feature unification: syn, quote and proc-macro2 as the proc-macros use them).
fn main() {}
