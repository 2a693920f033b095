//! House rules, checked on every `cargo test`: file headers, no ignored or should-panic
//! tests, workspace-wide crate settings, and the dependency boundaries of
//! `docs/ARCHITECTURE.md`.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n == "target" || n == "snapshots") {
                continue;
            }
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

fn crates() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(root().join("crates")).expect("crates/").flatten().map(|e| e.path()).collect();
    dirs.push(root().join("xtask"));
    dirs.sort();
    dirs
}

#[test]
fn every_source_file_opens_with_a_module_comment() {
    let mut files = Vec::new();
    for dir in crates() {
        rust_files(&dir, &mut files);
    }
    assert!(files.len() > 20);
    for file in files {
        let text = std::fs::read_to_string(&file).expect("readable");
        assert!(text.starts_with("//!"), "{} does not open with a `//!` line saying what it is for", file.display());
    }
}

#[test]
fn no_ignored_or_should_panic_tests() {
    let mut files = Vec::new();
    for dir in crates() {
        rust_files(&dir, &mut files);
    }
    let banned = [concat!("#[", "ignore"), concat!("#[", "should_panic")];
    for file in files {
        let text = std::fs::read_to_string(&file).expect("readable");
        for pattern in banned {
            assert!(!text.contains(pattern), "{} contains `{pattern}`", file.display());
        }
    }
}

/// The `[dependencies]` of a crate that are workspace crates.
fn internal_dependencies(manifest: &str, workspace_crates: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_dependencies = false;
    for line in manifest.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            in_dependencies = line == "[dependencies]";
            continue;
        }
        if in_dependencies && let Some((name, _)) = line.split_once(['.', '=']) {
            let name = name.trim().to_string();
            if workspace_crates.contains(&name) {
                out.push(name);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn crates_share_settings_and_respect_their_boundaries() {
    let names: Vec<String> = crates().iter().map(|d| d.file_name().unwrap_or_default().to_string_lossy().into_owned()).collect();
    // What each library crate may depend on inside the workspace (docs/ARCHITECTURE.md).
    let allowed: &[(&str, &[&str])] = &[
        ("pddl-syntax", &[]),
        ("benchmark-data", &[]),
        ("grounding", &["pddl-syntax"]),
        ("transition-model", &["grounding"]),
        ("heuristics", &["grounding", "transition-model"]),
        ("token-constraint", &["grounding", "transition-model"]),
        ("vlm-client", &[]),
        // The server backend's HTTP is vlm-client's transport; `LocalChat` is a vlm-client
        // `ChatModel`.
        ("lm", &["vlm-client"]),
        ("mcts", &["grounding", "transition-model", "heuristics", "token-constraint", "lm"]),
        ("household-sim", &["pddl-syntax", "grounding", "transition-model"]),
        ("eval-harness", &[]),
        // No code: cargo-hakari's feature unification (its Cargo.toml says why).
        ("workspace-hack", &[]),
        (
            "exploration-harness",
            &[
                "pddl-syntax",
                "household-sim",
                "vlm-client",
                // mcts without its decoder (the prompt, the tree summary): no model, no lm.
                "mcts",
                "grounding",
                "transition-model",
                "heuristics",
                "token-constraint",
            ],
        ),
    ];
    let architecture = std::fs::read_to_string(root().join("docs/ARCHITECTURE.md")).expect("docs/ARCHITECTURE.md");
    for (dir, name) in crates().iter().zip(&names) {
        let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).expect("Cargo.toml");
        assert!(manifest.contains(&format!("name = \"{name}\"")), "{name}: directory name == crate name");
        // The hack is 0.1.0: it stands, through [patch.crates-io], in the place of crates.io's stub.
        let version = if name == "workspace-hack" { "0.1.0" } else { "0.0.0" };
        assert!(manifest.contains(&format!("version = \"{version}\"")), "{name}: internal crates are version 0.0.0, the hack 0.1.0");
        assert!(manifest.contains("publish.workspace = true"), "{name}: publish = false via the workspace");
        assert!(manifest.contains("[lints]\nworkspace = true"), "{name}: uses the workspace lint table");
        assert!(architecture.contains(&format!("`{name}`")), "{name} is missing from docs/ARCHITECTURE.md");
        // Every member but the hack itself takes it: that is what unifies the features.
        let dependencies = internal_dependencies(&manifest, &names);
        assert_eq!(
            dependencies.iter().any(|d| d == "workspace-hack"),
            name != "workspace-hack",
            "{name}: every member depends on workspace-hack (`cargo hakari manage-deps`)"
        );
        if name == "xtask" {
            continue;
        }
        let rule = allowed
            .iter()
            .find(|(crate_name, _)| crate_name == name)
            .unwrap_or_else(|| panic!("{name}: add its dependency rule to tidy.rs"));
        for dependency in dependencies.iter().filter(|d| *d != "workspace-hack") {
            assert!(rule.1.contains(&dependency.as_str()), "{name} must not depend on {dependency}");
        }
    }
    // Members name crates.io's empty stub; only this workspace's [patch] makes it ours, so a
    // project that takes one of our crates by git or path does not build the hack's union.
    let root_manifest = std::fs::read_to_string(root().join("Cargo.toml")).expect("Cargo.toml");
    assert!(section(&root_manifest, "[workspace.dependencies]").contains(&"workspace-hack = \"0.1\""), "the stub by version, no path");
    assert!(section(&root_manifest, "[patch.crates-io]").contains(&"workspace-hack = { path = \"crates/workspace-hack\" }"));
}

/// The `[section]` of a manifest, as its lines (trimmed, comments and blanks dropped).
fn section<'a>(manifest: &'a str, name: &str) -> Vec<&'a str> {
    let mut out = Vec::new();
    let mut inside = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            inside = line == name;
            continue;
        }
        if inside && !line.is_empty() && !line.starts_with('#') {
            out.push(line);
        }
    }
    out
}

#[test]
fn dependencies_are_declared_once_and_crates_build_alone() {
    // Every dependency of a member comes from `[workspace.dependencies]`: one version each.
    // The hack crate's are written by `cargo hakari generate`, which CI checks is current.
    for dir in crates().into_iter().filter(|d| !d.ends_with("workspace-hack")) {
        let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).expect("Cargo.toml");
        for table in ["[dependencies]", "[dev-dependencies]", "[build-dependencies]"] {
            for line in section(&manifest, table) {
                let (name, spec) = line.split_once('=').expect("name = spec");
                let (name, spec) = (name.trim(), spec.trim());
                let own_path = spec.contains("path = \".\"");
                assert!(
                    name.ends_with(".workspace") || spec.contains("workspace = true") || own_path,
                    "{}: `{line}` in {table}: declare it in the root [workspace.dependencies] and use `workspace = true`",
                    dir.display()
                );
            }
        }
    }
    let manifest = |name: &str| std::fs::read_to_string(root().join("crates").join(name).join("Cargo.toml")).expect("manifest");
    // token-constraint's byte-level core builds without the planner.
    let token_constraint = manifest("token-constraint");
    for planner in ["grounding", "transition-model"] {
        assert!(
            section(&token_constraint, "[dependencies]").iter().any(|l| l.starts_with(planner) && l.contains("optional = true")),
            "token-constraint: {planner} must be optional (feature `planning`)"
        );
    }
    assert!(section(&token_constraint, "[features]").contains(&"default = [\"planning\"]"));
    // lm's backends are features, and mcts takes lm without them (no network client).
    let lm = manifest("lm");
    for client in ["vlm-client", "ureq"] {
        assert!(
            section(&lm, "[dependencies]").iter().any(|l| l.starts_with(client) && l.contains("optional = true")),
            "lm: {client} must be optional (feature `openai`)"
        );
    }
    let workspace = std::fs::read_to_string(root().join("Cargo.toml")).expect("root manifest");
    assert!(workspace.contains("lm = { path = \"crates/lm\", default-features = false }"), "members choose lm's backends");
    let mcts = manifest("mcts");
    assert!(
        section(&mcts, "[dependencies]").contains(&"lm = { workspace = true, optional = true }"),
        "mcts depends on lm's interface alone"
    );
    // mcts's decoder (lm, the masks) is a feature that exploration-harness does not take: Phase
    // I and the episode build without a model crate in their tree.
    assert!(section(&mcts, "[features]").contains(&"default = [\"decoder\"]"));
    assert!(workspace.contains("mcts = { path = \"crates/mcts\", default-features = false }"), "members choose mcts's decoder");
    assert!(
        section(&manifest("exploration-harness"), "[dependencies]").contains(&"mcts.workspace = true"),
        "exploration-harness: mcts without the decoder"
    );
    // And what cargo resolves for it alone: no model crate in its normal dependency tree.
    let tree = std::process::Command::new(env!("CARGO"))
        .args(["tree", "--offline", "--locked", "-e", "normal", "--prefix", "none", "-p", "exploration-harness"])
        .current_dir(root())
        .output()
        .expect("cargo tree runs");
    assert!(tree.status.success(), "{}", String::from_utf8_lossy(&tree.stderr));
    let tree = String::from_utf8_lossy(&tree.stdout);
    for model_crate in ["lm ", "candle-core ", "tokenizers ", "llguidance "] {
        assert!(!tree.lines().any(|l| l.starts_with(model_crate)), "exploration-harness builds {model_crate}:\n{tree}");
    }
    assert!(tree.lines().any(|l| l.starts_with("mcts ")), "{tree}");
    // benchmark-data: the compile-time path is one fallback, behind a root callers can pass.
    let data = std::fs::read_to_string(root().join("crates/benchmark-data/src/lib.rs")).expect("lib.rs");
    assert_eq!(data.matches("env!(\"CARGO_MANIFEST_DIR\")").count(), 1, "benchmark-data: only Fixtures::checkout may use the build path");
    assert!(data.contains("pub fn at(root: impl Into<PathBuf>) -> Fixtures"));
}

/// Property tests are reproducible and remember their failures: every `proptest!` block
/// fixes its seed and keeps regressions beside its source (committed when one is found).
#[test]
fn property_tests_are_seeded_and_keep_their_regressions() {
    let mut files = Vec::new();
    for dir in crates() {
        rust_files(&dir, &mut files);
    }
    let mut blocks = 0;
    for file in files {
        let text = std::fs::read_to_string(&file).expect("readable");
        if file.ends_with("tidy.rs") {
            continue;
        }
        let count = text.matches(concat!("proptest", "! {")).count();
        if count == 0 {
            continue;
        }
        blocks += count;
        // Each block sets its config; the file fixes the seed and keeps regressions (inline,
        // or in a helper the blocks call).
        assert_eq!(text.matches("#![proptest_config(").count(), count, "{}: a proptest! block without its config", file.display());
        assert!(text.contains("RngSeed::Fixed("), "{}: property tests without a fixed rng_seed", file.display());
        assert!(
            text.contains("FileFailurePersistence::WithSource(\"proptest-regressions\")"),
            "{}: property tests that do not keep their regressions",
            file.display()
        );
    }
    assert!(blocks >= 10, "{blocks} proptest! blocks found");
}
