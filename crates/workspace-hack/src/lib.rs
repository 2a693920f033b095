//! No code: a dependency of every member that unifies the features of third-party crates across
//! the workspace's builds (the cargo-hakari pattern; see this crate's `Cargo.toml`).
