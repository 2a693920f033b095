//! The evidence update and ALFWorld's perceiver against the real state: on fixture games
//! (the walkthrough and a seeded random walk), every fact the perceiver reads off an
//! observation holds in the hidden state at that step (checked through the environment's
//! judge, which no agent gets); and U never admits a fact no observation stated, whatever a
//! proposer claims (property test).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use exploration_harness::{Belief, Fact, Percept, perceive_alfworld};
use household_sim::{AlfworldEnv, Environment, Judge, JudgeAtom, PythonRandom};
use proptest::prelude::*;

fn games() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/alfworld/valid_seen");
    let mut out = Vec::new();
    for family in std::fs::read_dir(&root).unwrap() {
        for trial in std::fs::read_dir(family.unwrap().path()).unwrap() {
            out.push(trial.unwrap().path().join("game.tw-pddl"));
        }
    }
    out.sort();
    out
}

/// Whether the judge's atoms make `fact` true (or false, as the fact says).
fn judged(fact: &Fact, atoms: &[JudgeAtom]) -> bool {
    let present = atoms.iter().any(|a| {
        a.predicate.eq_ignore_ascii_case(&fact.predicate)
            && if fact.predicate == "holds" { a.args.last() == fact.args.last() } else { a.args == fact.args }
    });
    present == fact.holds
}

/// Plays `commands` (or a seeded random walk when `None`), checking every percept.
fn check_game(path: &Path, commands: Option<&[String]>, seed: u64, checked: &mut usize) {
    let mut env = AlfworldEnv::from_game_file(path).unwrap();
    let first = env.reset();
    let mut steps: Vec<(String, String)> = vec![(String::new(), first.text)];
    let mut rng = PythonRandom::new(seed);
    for i in 0..commands.map_or(30, <[String]>::len) {
        let command = match commands {
            Some(c) => c[i].clone(),
            None => {
                let mut admissible = env.admissible_commands().unwrap();
                admissible.sort();
                admissible[rng.choice_index(admissible.len())].clone()
            }
        };
        let result = env.step(&command);
        steps.push((command.clone(), result.observation.text));
        let (_, percepts) = perceive_alfworld(&steps.last().unwrap().1, i + 1);
        let atoms = env.hidden_atoms();
        // `visited` records that the observation showed a place; it is not a state atom.
        for p in percepts.iter().filter(|p| p.fact.predicate != "visited") {
            assert!(
                judged(&p.fact, &atoms),
                "{}: step {} `{}`: {:?} does not hold\n{}",
                path.display(),
                i + 1,
                command,
                p.fact,
                steps.last().unwrap().1
            );
            *checked += 1;
        }
    }
    let (places, _) = perceive_alfworld(&steps[0].1, 0);
    assert!(!places.is_empty(), "{}: no places in the first observation", path.display());
}

#[test]
fn every_perceived_fact_holds_in_the_hidden_state() {
    let mut checked = 0;
    for path in games().into_iter().step_by(4) {
        let walkthrough = AlfworldEnv::from_game_file(&path).unwrap().walkthrough().to_vec();
        check_game(&path, Some(&walkthrough), 0, &mut checked);
        check_game(&path, None, 7, &mut checked);
    }
    eprintln!("{checked} perceived facts checked against the hidden state");
    assert!(checked > 500, "only {checked} facts checked");
}

#[test]
fn the_perceiver_reads_each_sentence_kind() {
    let (places, p) = perceive_alfworld(
        "-= Welcome to TextWorld, ALFRED! =-\n\nYou are in the middle of a room. Looking quickly around you, you see a cabinet 1, a fridge 1, and a countertop 1.\n\nYour task is to: put a clean mug in coffeemachine.",
        0,
    );
    assert_eq!(places, ["cabinet 1", "fridge 1", "countertop 1"]);
    assert!(p.is_empty());
    let facts =
        |text: &str| perceive_alfworld(text, 1).1.into_iter().map(|p| p.fact).filter(|f| f.predicate != "visited").collect::<Vec<_>>();
    let visited = |text: &str| {
        perceive_alfworld(text, 1)
            .1
            .into_iter()
            .filter(|p| p.fact.predicate == "visited")
            .map(|p| p.fact.args[0].clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(visited("You arrive at desk 1. On the desk 1, you see nothing."), ["desk 1", "desk 1"]);
    assert_eq!(visited("On the drawer 3, you see a cd 1."), ["drawer 3"]);
    assert!(visited("You pick up the cd 1 from the drawer 3.").is_empty());
    assert_eq!(
        facts("You arrive at countertop 1. On the countertop 1, you see a mug 2, and a apple 1."),
        [Fact::new("inReceptacle", &["mug 2", "countertop 1"], true), Fact::new("inReceptacle", &["apple 1", "countertop 1"], true)]
    );
    assert_eq!(
        facts("You open the fridge 1. The fridge 1 is open. In it, you see a egg 1."),
        [
            Fact::new("opened", &["fridge 1"], true),
            Fact::new("opened", &["fridge 1"], true),
            Fact::new("inReceptacle", &["egg 1", "fridge 1"], true)
        ]
    );
    assert_eq!(facts("You arrive at cabinet 1. The cabinet 1 is closed."), [Fact::new("opened", &["cabinet 1"], false)]);
    assert_eq!(
        facts("You pick up the mug 2 from the countertop 1."),
        [Fact::new("holds", &["mug 2"], true), Fact::new("inReceptacle", &["mug 2", "countertop 1"], false)]
    );
    assert_eq!(facts("You clean the mug 2 using the sinkbasin 1."), [Fact::new("isClean", &["mug 2"], true)]);
    assert!(facts("Nothing happens.").is_empty());
    assert!(facts("You arrive at bed 1. On the bed 1, you see nothing.").is_empty());
}

fn fact_strategy() -> impl Strategy<Value = Fact> {
    let names = prop::sample::select(vec!["mug 2", "apple 1", "fridge 1", "countertop 1", "cabinet 3", "egg 1"]);
    let predicates = prop::sample::select(vec!["inReceptacle", "opened", "holds", "isClean", "isHot"]);
    (predicates, prop::collection::vec(names, 1..3), any::<bool>()).prop_map(|(p, args, holds)| Fact::new(p, &args, holds))
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20261201),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    /// Whatever a proposer claims, F_t holds only what percepts stated, each with the latest word.
    #[test]
    fn proposals_never_enter_the_established_facts(
        rounds in prop::collection::vec((prop::collection::vec(fact_strategy(), 0..4), prop::collection::vec(fact_strategy(), 0..4)), 1..12)
    ) {
        let mut belief = Belief::default();
        let mut stated: Vec<Fact> = Vec::new();
        for (step, (seen, proposed)) in rounds.iter().enumerate() {
            belief.propose(proposed);
            let percepts: Vec<Percept> = seen.iter().map(|f| Percept { fact: f.clone(), step }).collect();
            belief.admit(&percepts);
            stated.extend(seen.iter().cloned());
        }
        let stated_set: BTreeSet<&Fact> = stated.iter().collect();
        for fact in belief.facts() {
            prop_assert!(stated_set.contains(&fact), "{fact:?} was never stated");
            // The latest statement about the atom wins.
            let latest = stated.iter().rev().find(|s| s.atom() == fact.atom()).unwrap();
            prop_assert_eq!(latest.holds, fact.holds);
        }
        for h in belief.hypotheses() {
            prop_assert!(belief.holds(&h.predicate, &h.args.iter().map(String::as_str).collect::<Vec<_>>()).is_none() || !stated_set.contains(h));
        }
    }
}
