//! `cargo xtask ontology`: derives F_str, each benchmark's fixed class-level ontology, from its
//! sources (ALFWorld's `valid_train` games; EAI's `properties_data.json` and
//! `class_name_equivalence.json`) with
//! `exploration_harness::ontology` and writes `fixtures/ontology/{alfworld,virtualhome}.txt`.
//! `crates/exploration-harness/tests/ontology.rs` requires the files to match a fresh derivation.

use std::process::ExitCode;

use anyhow::Context;
use exploration_harness::ontology::{alfworld_from_problems, virtualhome_from_properties};

use crate::input::InputError;

pub fn run() -> anyhow::Result<ExitCode> {
    let fixtures = benchmark_data::fixtures_dir();
    let mut problems = Vec::new();
    let root = fixtures.join("alfworld/valid_train");
    for family in std::fs::read_dir(&root).with_context(|| format!("cannot read {}", root.display()))? {
        for trial in std::fs::read_dir(family?.path())? {
            let path = trial?.path().join("game.tw-pddl");
            let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
            let game: serde_json::Value = serde_json::from_str(&text).map_err(|e| InputError(format!("{}: {e}", path.display())))?;
            let problem = game["pddl_problem"].as_str().ok_or_else(|| InputError(format!("{}: no pddl_problem", path.display())))?;
            problems.push((path.display().to_string(), problem.to_string()));
        }
    }
    problems.sort();
    let alfworld = alfworld_from_problems(problems.iter().map(|(o, t)| (o.as_str(), t.as_str()))).map_err(|e| InputError(e.to_string()))?;
    let source = fixtures.join("virtualhome-eai/properties_data.json");
    let text = std::fs::read_to_string(&source).with_context(|| format!("cannot read {}", source.display()))?;
    let mut virtualhome = virtualhome_from_properties(&text, &source.display().to_string()).map_err(|e| InputError(e.to_string()))?;
    let source = fixtures.join("virtualhome-eai/class_name_equivalence.json");
    let text = std::fs::read_to_string(&source).with_context(|| format!("cannot read {}", source.display()))?;
    virtualhome.add_equivalences(&text, &source.display().to_string()).map_err(|e| InputError(e.to_string()))?;
    let out = fixtures.join("ontology");
    std::fs::create_dir_all(&out)?;
    std::fs::write(out.join("alfworld.txt"), alfworld.to_text())?;
    std::fs::write(out.join("virtualhome.txt"), virtualhome.to_text())?;
    eprintln!(
        "ALFWorld ({} games): {} classes, {} canContain pairs, {} classes whose instances disagree; VirtualHome: {} classes, {} names with equivalents",
        problems.len(),
        alfworld.affordances.len(),
        alfworld.can_contain.len(),
        alfworld.disagreements.len(),
        virtualhome.affordances.len(),
        virtualhome.same_as.len()
    );
    println!("{}", out.display());
    Ok(ExitCode::SUCCESS)
}
