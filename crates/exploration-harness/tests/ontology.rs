//! F_str: the committed ontologies in `fixtures/ontology/` are what the derivation functions
//! produce from their sources (ALFWorld's `valid_train` games; EAI's `properties_data.json`),
//! and they say what the benchmarks need.

use std::path::{Path, PathBuf};

use exploration_harness::Ontology;
use exploration_harness::ontology::{alfworld_from_problems, virtualhome_from_properties};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// `(origin, problem text)` of every game of an ALFWorld split.
pub fn alfworld_problems(split: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let root = fixtures().join("alfworld").join(split);
    for family in std::fs::read_dir(&root).unwrap() {
        for trial in std::fs::read_dir(family.unwrap().path()).unwrap() {
            let path = trial.unwrap().path().join("game.tw-pddl");
            let game: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
            out.push((path.display().to_string(), game["pddl_problem"].as_str().unwrap().to_string()));
        }
    }
    out.sort();
    out
}

#[test]
fn the_committed_alfworld_ontology_is_derived_from_the_training_split() {
    let problems = alfworld_problems("valid_train");
    assert_eq!(problems.len(), 200);
    let derived = alfworld_from_problems(problems.iter().map(|(o, t)| (o.as_str(), t.as_str()))).unwrap();
    let path = fixtures().join("ontology/alfworld.txt");
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert_eq!(committed, derived.to_text(), "{} is stale: `cargo xtask ontology` writes it again", path.display());
    assert_eq!(Ontology::from_text(&committed, "alfworld.txt").unwrap(), derived);
    // What the six task types need.
    for (class, affordance) in [
        ("fridge", "openable"),
        ("microwave", "openable"),
        ("apple", "heatable"),
        ("apple", "pickupable"),
        ("desklamp", "toggleable"),
        ("mug", "cleanable"),
    ] {
        assert!(derived.affordances.get(class).is_some_and(|a| a.contains(affordance)), "{class} {affordance}");
    }
    assert!(derived.can_contain.contains(&("fridge".to_string(), "apple".to_string())));
}

#[test]
fn the_committed_virtualhome_ontology_is_eais_properties() {
    let source = fixtures().join("virtualhome-eai/properties_data.json");
    let mut derived = virtualhome_from_properties(&std::fs::read_to_string(&source).unwrap(), "properties_data.json").unwrap();
    let names = fixtures().join("virtualhome-eai/class_name_equivalence.json");
    derived.add_equivalences(&std::fs::read_to_string(&names).unwrap(), "class_name_equivalence.json").unwrap();
    let path = fixtures().join("ontology/virtualhome.txt");
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert_eq!(committed, derived.to_text(), "{} is stale: `cargo xtask ontology` writes it again", path.display());
    assert_eq!(Ontology::from_text(&committed, "virtualhome.txt").unwrap(), derived);
    assert!(derived.affordances["dishwasher"].contains("can_open"));
    assert!(derived.affordances["plate"].contains("grabbable"));
    assert_eq!(derived.same_as.len(), 129);
}

/// A task sentence names the rooms of EAI's scenes by the benchmark's own names for them.
#[test]
fn a_sentence_names_a_room_by_any_name_of_its_class() {
    let ontology =
        Ontology::from_text(&std::fs::read_to_string(fixtures().join("ontology/virtualhome.txt")).unwrap(), "virtualhome.txt").unwrap();
    let names = |sentence: &str| -> Vec<&str> {
        ["bathroom", "bedroom", "dining_room", "home_office"].into_iter().filter(|room| ontology.sentence_names(sentence, room)).collect()
    };
    // EAI 117_1, 1068_1, 264_1, 232_2, 149_1, 996_2, 446_2: the equivalence table, the class
    // itself, its head noun, two words joined.
    assert_eq!(names("Go to the living room. Find the remote."), ["home_office"]);
    assert_eq!(names("walk to home office ,find computer"), ["home_office"]);
    assert_eq!(names("Enter office. Go to desk. Pick up phone."), ["home_office"]);
    assert_eq!(names("I need to turn on the lights in the kitchen so I can make dinner."), ["dining_room"]);
    assert_eq!(names("stand up, walk to Entrance Hall, walk to table"), ["home_office"]);
    assert_eq!(names("I go to my bed room and sit on the chair"), ["bedroom"]);
    assert_eq!(names("Go to kitchen, grab dishes, walk to dining room"), ["dining_room"]);
    // `room` heads two names, so it names neither; a sentence without a place names none.
    assert_eq!(names("I would walk to my room where my phone is plugged in"), Vec::<&str>::new());
    assert_eq!(names("Turn on the TV, sit on the couch, find a show, and watch it."), Vec::<&str>::new());
}

/// The classes a task sentence names, read once.
#[test]
fn a_sentence_names_the_classes_of_its_objects() {
    let ontology =
        Ontology::from_text(&std::fs::read_to_string(fixtures().join("ontology/virtualhome.txt")).unwrap(), "virtualhome.txt").unwrap();
    // EAI 342_2 and 225_2: `couch` is one of the names of `couch`/`sofa`; a two-word name.
    let couch = ontology.sentence_classes("Turn on the TV, sit on the couch, find a show, and watch it.");
    assert!(couch.contains("couch"), "{couch:?}");
    assert!(couch.contains("television"), "{couch:?}");
    let table = ontology.sentence_classes("Sit down, turn on the TV with the remote control that is on the coffee table.");
    assert!(table.contains("remote_control") && table.contains("coffee_table"), "{table:?}");
    assert!(!table.contains("coffee"), "{table:?}");
    // A head noun alone names no object (EAI 864_2: "can" heads `garbage_can`), nor does a word
    // of two that join into a known name ("food egg" is `food_egg`, and `food` heads `food_food`).
    let can = ontology.sentence_classes("I'll then use my hand to pick up the phone such that I can then use it.");
    assert!(can.contains("phone") && !can.contains("garbage_can"), "{can:?}");
    assert!(ontology.sentence_names("I can", "garbage_can"));
    let egg = ontology.sentence_classes("Put the food egg in the microwave, close it and switch it on.");
    assert!(egg.contains("food_egg") && egg.contains("microwave"), "{egg:?}");
    assert!(!egg.contains("food_food"), "{egg:?}");
    assert!(ontology.sentence_classes("").is_empty());
}

#[test]
fn bad_equivalences_name_the_file_and_the_name() {
    let mut ontology = Ontology::default();
    let error = ontology.add_equivalences(r#"{"couch": ["sofa"], "tv": "television"}"#, "names.json").unwrap_err();
    assert_eq!((error.origin.as_str(), error.message.as_str()), ("names.json", "`tv`: not a list"));
    let error = ontology.add_equivalences(r#"{"couch": [3]}"#, "names.json").unwrap_err();
    assert_eq!(error.message, "`couch`: a name that is not a string");
    assert!(ontology.add_equivalences("[", "names.json").unwrap_err().message.starts_with("not JSON"));
    ontology.add_equivalences(r#"{"Couch": ["SOFA"]}"#, "names.json").unwrap();
    assert!(ontology.same_class("couch", "sofa"));
}

#[test]
fn bad_ontology_text_names_the_line() {
    let error = Ontology::from_text("affordance mug pickupable\ncancontain fridge\n", "x.txt").unwrap_err();
    assert_eq!(error.origin, "x.txt:2");
}
