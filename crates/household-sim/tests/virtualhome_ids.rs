//! The id rule of `VirtualhomeEnv` under `IdScope::Perceived`, checked against the text the
//! agent was shown (every id here the agent's, not the scene's): on EAI fixture scenes, random instance-level lines (objects the observation
//! lists, objects it does not, right and wrong classes, the character) are refused for their id
//! exactly when `class (id)` has not appeared in an observation since the reset; a refused line
//! changes nothing and never reaches the engine script.

use std::collections::BTreeSet;
use std::path::PathBuf;

use household_sim::{Environment, Event, Judge, VirtualhomeEnv, VirtualhomeTask};
use proptest::prelude::*;

fn task(name: &str) -> VirtualhomeTask {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/virtualhome-eai/graphs").join(name);
    VirtualhomeTask::load(&path).expect("fixture task loads")
}

/// Every `class (id)` an observation names (`fridge (289)`), its first line left out: the
/// outcome of the step (`Executed [WALK] <fridge> (289).`, or `Not executed: ` and a reason
/// that may repeat the refused line's names) is not a sight of the scene.
fn named(text: &str, into: &mut BTreeSet<(String, u32)>) {
    let text = match text.split_once('\n') {
        Some((first, rest)) if first.starts_with("Executed ") || first.starts_with("Not executed: ") => rest,
        _ => text,
    };
    let mut at = 0;
    while let Some(found) = text[at..].find(" (") {
        let open = at + found;
        at = open + 2;
        let Some(close) = text[at..].find(')') else { break };
        let Ok(id) = text[at..at + close].parse::<u32>() else { continue };
        // Class names hold letters, digits, `_` and `-` (`shoe-shine_kit`); the echo's `<c> (id)`
        // ends in `>` and is read as no name.
        let start = text[..open].rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '-')).map_or(0, |i| i + 1);
        if start < open {
            into.insert((text[start..open].to_string(), id));
        }
    }
}

const VERBS: &[&str] = &["WALK", "OPEN", "GRAB", "CLOSE", "SWITCHON", "PUTBACK"];

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 48,
        rng_seed: proptest::test_runner::RngSeed::Fixed(62),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn a_line_is_refused_for_its_ids_exactly_when_they_were_not_shown(
        which in 0usize..4,
        picks in proptest::collection::vec((0usize..VERBS.len(), any::<u16>(), any::<u16>(), 0u8..10), 1..30),
    ) {
        let task = task(["1004_2.json.gz", "152_2.json.gz", "1083_2.json.gz", "229_1.json.gz"][which]);
        let graph = task.init.graph.clone();
        let character = task.init.character;
        let mut env = VirtualhomeEnv::new(task, "virtualhome-eai");
        // Every node by the id the agent is shown for it (not the scene's).
        let shown_id = |ix| env.shown_id(graph.node(ix).id).expect("a node");
        let nodes: Vec<(String, u32)> = graph.indices().map(|ix| (graph.node(ix).class_name.clone(), shown_id(ix))).collect();
        let character_id = shown_id(character);
        let mut shown = BTreeSet::new();
        named(&env.reset().text, &mut shown);
        for (verb, a, b, how) in picks {
            // Mostly what is in view now; else any node of the scene, sometimes under the class
            // of another node, or the character.
            let visible = env.visible_objects();
            let pick = |n: u16| -> (String, u32) {
                match how {
                    0..=5 if !visible.is_empty() => { let (id, class) = &visible[n as usize % visible.len()]; (class.clone(), *id) }
                    // A node in view named under another node's class (often another class).
                    6 => (nodes[(n as usize + 1 + b as usize) % nodes.len()].0.clone(), visible[a as usize % visible.len()].0),
                    7 => (graph.node(character).class_name.clone(), character_id),
                    _ => nodes[n as usize % nodes.len()].clone(),
                }
            };
            let verb = VERBS[verb];
            let objects = if verb == "PUTBACK" { vec![pick(a), pick(b)] } else { vec![pick(a)] };
            let line = std::iter::once(format!("[{verb}]")).chain(objects.iter().map(|(c, id)| format!("<{c}> ({id})"))).collect::<Vec<_>>().join(" ");
            let script_before = env.engine_script().len();
            let state_before = env.hidden_atoms();
            let result = env.step(&line);
            let unseen = objects.iter().find(|o| o.1 == character_id || !shown.contains(*o));
            match (&result.event, unseen) {
                (Event::NotExecuted { reason }, Some((class, id))) => {
                    let expected = if *id == character_id {
                        format!("the character ({id}) is not an object to name")
                    } else {
                        format!("no {class} ({id}) has been seen")
                    };
                    prop_assert_eq!(reason, &expected, "{}", line);
                    prop_assert_eq!(env.engine_script().len(), script_before, "a refused id never reaches the engine: {}", line);
                    prop_assert!(env.hidden_atoms() == state_before, "a refused id changes nothing: {}", line);
                }
                (Event::Executed, Some(object)) => prop_assert!(false, "{line} executed, but {object:?} was never shown"),
                (Event::NotExecuted { reason }, None) => {
                    prop_assert!(!reason.contains("has been seen") && !reason.contains("not an object to name"), "{line}: {reason}");
                    prop_assert_eq!(env.engine_script().len(), script_before + 1, "a line of shown ids reaches the engine: {}", line);
                }
                (Event::Executed, None) => {}
            }
            named(&result.observation.text, &mut shown);
        }
    }
}
