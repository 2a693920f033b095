//! VirtualhomeEnv on a tiny hand-made scene: preconditions, effects, the CLOSE edges walking
//! creates, visibility, class-level binding, the full goal check, and bad input.
//!
//! ```text
//!   kitchen (1) ── character (2)           livingroom (50) ── tv (51) [OFF]
//!     ├─ fridge (10) [CLOSED]  ⊃ apple (11)
//!     ├─ table (20)  ◁ON─ plate (21), plate (22)
//!     └─ dishwasher (30) [CLOSED, OFF]
//! ```

use household_sim::{EngineLine, Environment, Event, IdScope, Judge, VirtualhomeEnv, VirtualhomeError, VirtualhomeTask};

fn scene(goal: &str) -> String {
    let node = |id: u32, class: &str, category: &str, props: &str, states: &str| {
        format!(r#"{{"id":{id},"class_name":"{class}","category":"{category}","properties":[{props}],"states":[{states}]}}"#)
    };
    let nodes = [
        node(1, "kitchen", "Rooms", "", ""),
        node(2, "character", "Characters", "", ""),
        node(10, "fridge", "Appliances", r#""CAN_OPEN","CONTAINERS""#, r#""CLOSED""#),
        node(11, "apple", "food", r#""GRABBABLE","EATABLE""#, ""),
        node(20, "table", "Furniture", r#""SURFACES""#, ""),
        node(21, "plate", "placable_objects", r#""GRABBABLE","RECIPIENT""#, r#""DIRTY""#),
        node(22, "plate", "placable_objects", r#""GRABBABLE","RECIPIENT""#, ""),
        node(30, "dishwasher", "Appliances", r#""CAN_OPEN","HAS_SWITCH","CONTAINERS""#, r#""CLOSED","OFF""#),
        node(50, "livingroom", "Rooms", "", ""),
        node(51, "tv", "Electronics", r#""HAS_SWITCH","LOOKABLE""#, r#""OFF""#),
    ]
    .join(",");
    let edge = |a: u32, r: &str, b: u32| format!(r#"{{"from_id":{a},"relation_type":"{r}","to_id":{b}}}"#);
    let edges = [
        edge(2, "INSIDE", 1),
        edge(10, "INSIDE", 1),
        edge(11, "INSIDE", 10),
        edge(11, "INSIDE", 1),
        edge(20, "INSIDE", 1),
        edge(21, "INSIDE", 1),
        edge(21, "ON", 20),
        edge(22, "INSIDE", 1),
        edge(22, "ON", 20),
        edge(30, "INSIDE", 1),
        edge(51, "INSIDE", 50),
    ]
    .join(",");
    format!(
        r#"{{"task_id":"t1","task_name":"Tiny","description":"Put a plate in the dishwasher.","vh_goal":{goal},"init_graph":{{"nodes":[{nodes}],"edges":[{edges}]}}}}"#
    )
}

const PLATE_IN_DISHWASHER: &str =
    r#"{"actions":[],"goal":[{"from_id":21,"relation_type":"INSIDE","to_id":30},{"id":30,"class_name":"dishwasher","state":"ON"}]}"#;

fn env(goal: &str) -> VirtualhomeEnv {
    let task = VirtualhomeTask::from_json(&scene(goal), "tiny.json").expect("tiny scene parses");
    let mut env = VirtualhomeEnv::new(task, "virtualhome-eai").with_id_scope(IdScope::Any);
    env.reset();
    env
}

/// Sends `commands` and checks each one's executed flag.
fn check(env: &mut VirtualhomeEnv, commands: &[(&str, bool)]) {
    for (i, (command, expected)) in commands.iter().enumerate() {
        let result = env.step(command);
        assert_eq!(result.event.executed(), *expected, "step {} {command}: {:?}", i + 1, result.event);
    }
}

#[test]
fn grabbing_needs_closeness_and_walking_makes_the_target_and_its_surface_close() {
    let mut e = env(PLATE_IN_DISHWASHER);
    check(&mut e, &[("[GRAB] <plate> (21)", false), ("[WALK] <plate> (21)", true), ("[GRAB] <plate> (21)", true)]);
    // Walking to the plate made the table close; the other plate is on it, so close too (the loose rule).
    check(&mut e, &[("[GRAB] <plate> (22)", true), ("[GRAB] <apple> (11)", false)]);
}

/// By default an instance-level line may name only a node an observation has shown since the
/// reset, with the class it was shown with: the tv in the other room and the apple in the
/// closed fridge are refused (nothing changes, nothing reaches the engine script) until they
/// are seen; once seen they stay nameable. `IdScope::Any` takes every node, as EAI's executor.
#[test]
fn instance_level_lines_name_only_what_has_been_seen() {
    let task = VirtualhomeTask::from_json(&scene(PLATE_IN_DISHWASHER), "tiny.json").unwrap();
    let mut e = VirtualhomeEnv::new(task.clone(), "virtualhome-eai");
    assert_eq!(e.id_scope(), IdScope::Perceived);
    // The agent's ids, not the scene's (module documentation of `virtualhome`, **Ids**).
    let [kitchen, fridge, apple, livingroom, tv, character] = [1, 10, 11, 50, 51, 2].map(|scene| e.shown_id(scene).expect("a node"));
    let step = |e: &mut VirtualhomeEnv, verb: &str, class: &str, id: u32| e.step(&format!("[{verb}] <{class}> ({id})"));
    assert!(!step(&mut e, "WALK", "fridge", fridge).event.executed(), "before the reset nothing has been shown");
    let start = e.reset().text;
    let refused = step(&mut e, "WALK", "tv", tv);
    assert_eq!(refused.event, Event::NotExecuted { reason: format!("no tv ({tv}) has been seen") });
    assert!(refused.observation.text.ends_with(&start), "nothing changed:\n{}", refused.observation.text);
    // A seen id under another class, an id the scene lacks, and the character are refused too.
    for (class, id, reason) in [
        ("tv", fridge, format!("no tv ({fridge}) has been seen")),
        ("tv", 99, "no tv (99) has been seen".to_string()),
        ("character", character, format!("the character ({character}) is not an object to name")),
    ] {
        assert_eq!(step(&mut e, "WALK", class, id).event, Event::NotExecuted { reason }, "{class} {id}");
    }
    assert!(step(&mut e, "WALK", "fridge", fridge).event.executed());
    assert!(!step(&mut e, "GRAB", "apple", apple).event.executed());
    assert!(step(&mut e, "OPEN", "fridge", fridge).event.executed());
    let grab = step(&mut e, "GRAB", "apple", apple);
    assert_eq!(grab.event, Event::Executed, "the open fridge showed the apple");
    // Walking to the livingroom (every room is listed) shows the tv; back in the kitchen it stays
    // nameable, and a reset forgets it.
    assert!(step(&mut e, "WALK", "livingroom", livingroom).event.executed());
    assert!(step(&mut e, "WALK", "kitchen", kitchen).event.executed());
    assert!(step(&mut e, "WALK", "tv", tv).event.executed());
    // The engine is given the scene's ids.
    let lines: Vec<String> = e.engine_script().into_iter().map(|l| l.line).collect();
    assert!(!lines.iter().any(|l| l.contains("(99)") || l.contains("<character>")), "refused lines never reach the engine: {lines:?}");
    assert_eq!(lines.first().map(String::as_str), Some("[WALK] <fridge> (10)"));
    assert_eq!(lines.last().map(String::as_str), Some("[WALK] <tv> (51)"));
    e.reset();
    assert!(!step(&mut e, "WALK", "tv", tv).event.executed());
    let mut any = VirtualhomeEnv::new(task, "virtualhome-eai").with_id_scope(IdScope::Any);
    any.reset();
    check(&mut any, &[("[WALK] <tv> (51)", true)]);
}

/// A class is compared as script lines read names (lower case, spaces as `_`, as EAI's parser):
/// a table shown as `Kitchen Table (N)` is named `<Kitchen Table> (N)` or `<kitchen_table> (N)`,
/// not `<table> (N)`.
#[test]
fn a_shown_class_is_compared_as_lines_read_it() {
    let text = scene(PLATE_IN_DISHWASHER).replace(r#""class_name":"table""#, r#""class_name":"Kitchen Table""#);
    let mut e = VirtualhomeEnv::new(VirtualhomeTask::from_json(&text, "tiny.json").unwrap(), "virtualhome-eai");
    let table = e.shown_id(20).expect("the table");
    assert!(e.reset().text.contains(&format!("- Kitchen Table ({table})")));
    check(
        &mut e,
        &[(format!("[WALK] <Kitchen Table> ({table})").as_str(), true), (format!("[WALK] <kitchen_table> ({table})").as_str(), true)],
    );
    assert_eq!(
        e.step(&format!("[WALK] <table> ({table})")).event,
        Event::NotExecuted { reason: format!("no table ({table}) has been seen") }
    );
}

#[test]
fn a_closed_container_hides_and_blocks_its_contents() {
    let mut e = env(PLATE_IN_DISHWASHER);
    let obs = e.reset().text;
    assert!(obs.contains("fridge (10): CLOSED"), "{obs}");
    assert!(!obs.contains("apple (11)"), "the apple inside the closed fridge is hidden:\n{obs}");
    check(&mut e, &[("[WALK] <fridge> (10)", true), ("[GRAB] <apple> (11)", false), ("[OPEN] <fridge> (10)", true)]);
    let obs = e.step("[GRAB] <apple> (11)");
    assert_eq!(obs.event, Event::Executed);
    assert!(obs.observation.text.contains("You hold: apple (11) in the right hand."), "{}", obs.observation.text);
}

#[test]
fn the_full_goal_needs_every_part_and_failed_steps_change_nothing() {
    let mut e = env(PLATE_IN_DISHWASHER);
    check(
        &mut e,
        &[
            ("[WALK] <dishwasher> (30)", true),
            ("[PUTIN] <plate> (21) <dishwasher> (30)", false),
            ("[WALK] <plate> (21)", true),
            ("[GRAB] <plate> (21)", true),
            ("[WALK] <dishwasher> (30)", true),
            ("[PUTIN] <plate> (21) <dishwasher> (30)", false),
            ("[OPEN] <dishwasher> (30)", true),
            ("[OPEN] <dishwasher> (30)", false),
            ("[PUTIN] <plate> (21) <dishwasher> (30)", true),
            ("[SWITCHON] <dishwasher> (30)", true),
        ],
    );
    // The dishwasher is on but still open: switching on an open dishwasher is allowed by the
    // executor; the goal asks only for the edge and ON.
    assert!(e.goal_reached(), "{:?}", e.unmet_goals());
    assert_eq!(e.steps_taken(), 10);
    e.reset();
    assert!(!e.goal_reached());
    assert_eq!(e.unmet_goals(), vec!["plate (21) INSIDE dishwasher (30)".to_string(), "dishwasher (30) is ON".to_string()]);
}

#[test]
fn action_goals_need_the_action_executed_in_order() {
    let goal = r#"{"actions":["WATCH|LOOKAT"],"goal":[{"id":51,"class_name":"tv","state":"ON"}]}"#;
    let mut e = env(goal);
    check(&mut e, &[("[WALK] <tv> (51)", true), ("[SWITCHON] <tv> (51)", true)]);
    assert_eq!(e.unmet_goals(), vec!["action WATCH|LOOKAT not done".to_string()]);
    check(&mut e, &[("[WATCH] <tv> (51)", false), ("[TURNTO] <tv> (51)", true), ("[WATCH] <tv> (51)", true)]);
    assert!(e.goal_reached());
}

#[test]
fn class_level_commands_bind_to_visible_instances_or_say_why_not() {
    let mut e = env(PLATE_IN_DISHWASHER);
    let r = e.step("grab apple");
    assert_eq!(r.event, Event::NotExecuted { reason: "apple could not be grounded from this pose".to_string() });
    let r = e.step("walk tv");
    assert!(!r.event.executed(), "the tv is in another room: not visible from the kitchen");
    check(&mut e, &[("walk plate", true), ("grab plate", true), ("grab plate", true)]);
    assert_eq!(&e.executed_lines()[1..], ["[GRAB] <plate> (21)", "[GRAB] <plate> (22)"]);
    check(&mut e, &[("walk dishwasher", true), ("open dishwasher", false)]);
    check(&mut e, &[("putback plate table", false)]);
}

#[test]
fn the_engine_script_holds_every_grounded_line_with_its_outcome() {
    let mut e = env(PLATE_IN_DISHWASHER);
    // No line: an action the executor does not know, a class with no instance in view.
    check(&mut e, &[("fly plate", false), ("grab apple", false)]);
    // Class-level commands become the instance-level lines the executor takes; a line the
    // preconditions refuse is kept with its outcome (the executor must refuse it too).
    check(
        &mut e,
        &[("[GRAB] <plate> (21)", false), ("walk plate", true), ("grab plate", true), ("walk fridge", true), ("grab apple", false)],
    );
    let line = |line: &str, executed: bool| EngineLine { line: line.to_string(), executed };
    assert_eq!(
        e.engine_script(),
        vec![
            line("[GRAB] <plate> (21)", false),
            line("[WALK] <plate> (21)", true),
            line("[GRAB] <plate> (21)", true),
            line("[WALK] <fridge> (10)", true),
        ],
        "the apple in the closed fridge is not in view: `grab apple` has no line"
    );
    e.reset();
    assert_eq!(e.engine_script(), vec![]);
}

#[test]
fn bad_commands_are_answered_never_panicked_on() {
    let mut e = env(PLATE_IN_DISHWASHER);
    for bad in [
        "",
        "   ",
        "[",
        "[WALK]",
        "[FLY] <x> (1)",
        "[WALK] <plate> (999)",
        "[WALK] <plate> (-1)",
        "[PUTIN] <plate> (21)",
        "fly kitchen",
        "walk",
    ] {
        assert!(!e.step(bad).event.executed(), "{bad:?}");
    }
    let noise: String = (0..10_000u32).map(|i| char::from_u32(32 + (i * 7919) % 95).unwrap_or('x')).collect();
    assert!(!e.step(&noise).event.executed());
    assert_eq!(e.steps_taken(), 11);
}

#[test]
fn bad_task_files_name_the_field() {
    let err = |text: String| VirtualhomeTask::from_json(&text, "t.json").expect_err("must be rejected").to_string();
    let missing_node = scene(r#"{"actions":[],"goal":[{"id":999,"class_name":"x","state":"ON"}]}"#);
    assert!(err(missing_node).contains("vh_goal.goal[0].id"));
    let bad_state = scene(PLATE_IN_DISHWASHER).replace(r#""DIRTY""#, r#""SHINY""#);
    assert!(err(bad_state).contains("nodes[5].states[0]"));
    let bad_edge = scene(PLATE_IN_DISHWASHER).replace(r#""relation_type":"ON","to_id":20"#, r#""relation_type":"UNDER","to_id":20"#);
    assert!(err(bad_edge).contains("edges[6].relation_type"));
    assert!(matches!(VirtualhomeTask::from_json("{", "t.json"), Err(VirtualhomeError::Json { .. })));
    // A file is named for its task, and its text is UTF-8 (the line of the first bad byte).
    let dir = std::env::temp_dir().join(format!("vh-task-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let text = scene(PLATE_IN_DISHWASHER);
    let renamed = dir.join("other_9.json");
    std::fs::write(&renamed, &text).expect("writes");
    let error = VirtualhomeTask::load(&renamed).expect_err("renamed").to_string();
    assert!(error.contains("task_id") && error.contains("`t1`, but the file is named for task `other_9`"), "{error}");
    let named = dir.join("t1.json");
    std::fs::write(&named, &text).expect("writes");
    VirtualhomeTask::load(&named).expect("the same task, named for itself");
    let mut bytes = text.clone().into_bytes();
    bytes.extend_from_slice(b"\n\n\xff");
    std::fs::write(&named, bytes).expect("writes");
    let error = VirtualhomeTask::load(&named).expect_err("not UTF-8").to_string();
    // A `.gz` file that is not gzip data is read as JSON, and said to be neither.
    let not_gzip = dir.join("t1.json.gz");
    std::fs::write(&not_gzip, "plain text").expect("writes");
    let gz_error = VirtualhomeTask::load(&not_gzip).expect_err("neither").to_string();
    std::fs::remove_dir_all(&dir).ok();
    assert!(error.contains(&format!("not UTF-8 text at line {}", text.lines().count() + 2)), "{error}");
    assert!(gz_error.contains("t1.json.gz: not valid task JSON: neither gzip data"), "{gz_error}");
}

#[test]
fn the_judge_sees_the_hidden_state_the_agent_does_not() {
    let e = env(PLATE_IN_DISHWASHER);
    let atoms: Vec<String> = e.hidden_atoms().iter().map(ToString::to_string).collect();
    assert!(atoms.contains(&"(INSIDE apple (11) fridge (10))".to_string()), "{atoms:?}");
    assert_eq!(e.goal().family, "Tiny");
    assert_eq!(e.admissible_commands(), None);
}

/// A script line built by hand with the wrong number of objects is the executor's failure, as
/// `ScriptLine::parse` refuses it, not a panic; the world is unchanged.
#[test]
fn a_hand_built_line_of_the_wrong_arity_fails_without_a_change() {
    use household_sim::{ScriptLine, VhAction};
    let task = VirtualhomeTask::from_json(&scene(PLATE_IN_DISHWASHER), "tiny.json").expect("tiny scene parses");
    let mut world = task.init.clone();
    let before = format!("{world:?}");
    let short = ScriptLine { action: VhAction::PutIn, objects: vec![("plate".into(), 21)] };
    assert_eq!(world.execute(&short), Err("Wrong number of parameters for \"PUTIN\". Got 1, expected 2".to_string()));
    let none = ScriptLine { action: VhAction::Walk, objects: Vec::new() };
    assert!(world.execute(&none).is_err());
    assert_eq!(format!("{world:?}"), before);
    let parsed = ScriptLine::parse("[PUTIN] <plate> (21)").expect_err("the parser refuses it too");
    assert_eq!(parsed, "Wrong number of parameters for \"PUTIN\". Got 1, expected 2");
}

/// The agent's ids (module documentation of `virtualhome`, **Ids**) on an EAI task whose goal
/// objects the task added (ids from 1000): a permutation of 1..=n, the same for every
/// environment of the task; every id the observation, the judge's atoms and the unmet goals
/// name is one of them; the engine script names the scene's ids; `IdScope::Any` shows the scene's.
#[test]
fn an_agent_is_shown_ids_of_the_environment_not_the_scenes() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/virtualhome-eai/graphs/201_1.json.gz");
    let task = VirtualhomeTask::load(&path).unwrap();
    let n = task.init.graph.len();
    let ids = household_sim::vh_shown_ids(&task.task_id, n);
    let mut sorted = ids.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (1..=n as u32).collect::<Vec<_>>());
    assert_ne!(ids, household_sim::vh_shown_ids("201_2", n), "another task, another permutation");
    let mut e = VirtualhomeEnv::new(task.clone(), "virtualhome-eai");
    assert_eq!(VirtualhomeEnv::new(task.clone(), "virtualhome-eai").shown_id(1000), e.shown_id(1000));
    let scene_ids: Vec<u32> = task.init.graph.indices().map(|ix| task.init.graph.node(ix).id).collect();
    for (ix, &scene) in scene_ids.iter().enumerate() {
        assert_eq!(e.shown_id(scene), Some(ids[ix]));
    }
    let id_in = |text: &str| -> Vec<u32> {
        text.split(" (").skip(1).filter_map(|rest| rest.split_once(')').and_then(|(id, _)| id.parse().ok())).collect()
    };
    let observation = e.reset().text;
    let dishwasher = e.shown_id(1000).unwrap();
    assert!(!observation.contains("(1000)"), "{observation}");
    let mut named: Vec<u32> = id_in(&observation);
    named.extend(e.hidden_atoms().iter().flat_map(|a| a.args.iter().flat_map(|arg| id_in(arg))));
    named.extend(e.unmet_goals().iter().flat_map(|g| id_in(g)));
    assert!(named.len() > 100 && named.iter().all(|&id| (1..=n as u32).contains(&id)), "{named:?}");
    // What the agent is shown is what the scene's ids show, each id the permutation's: the
    // replay environment's observation with its ids mapped has the same lines (in another order,
    // the order of the ids; the rooms' line too).
    let mut scene_view = VirtualhomeEnv::new(task.clone(), "virtualhome-eai").with_id_scope(IdScope::Any);
    let mapped: String = {
        let text = scene_view.reset().text;
        let mut out = String::new();
        let mut rest = text.as_str();
        while let Some(open) = rest.find(" (") {
            out.push_str(&rest[..open + 2]);
            rest = &rest[open + 2..];
            let close = rest.find(')').expect("a closing parenthesis");
            out.push_str(&e.shown_id(rest[..close].parse().expect("an id")).expect("a node").to_string());
            rest = &rest[close..];
        }
        out + rest
    };
    let lines = |text: &str| -> Vec<String> {
        let mut lines: Vec<String> = text
            .lines()
            .map(|line| match line.strip_prefix("Rooms: ") {
                Some(rooms) => {
                    let mut rooms: Vec<&str> = rooms.trim_end_matches('.').split(", ").collect();
                    rooms.sort_unstable();
                    format!("Rooms: {}.", rooms.join(", "))
                }
                None => line.to_string(),
            })
            .collect();
        lines.sort_unstable();
        lines
    };
    assert_eq!(lines(&mapped), lines(&observation));
    assert!(e.unmet_goals().iter().any(|g| g.contains(&format!("dishwasher ({dishwasher})"))), "{:?}", e.unmet_goals());
    // To the dining room, where the dishwasher is, by the agent's ids; the engine gets the scene's.
    let dining_room = e.shown_id(201).unwrap();
    assert!(e.step(&format!("[WALK] <dining_room> ({dining_room})")).event.executed());
    assert!(e.step(&format!("[WALK] <dishwasher> ({dishwasher})")).event.executed());
    let lines: Vec<String> = e.engine_script().into_iter().map(|l| l.line).collect();
    assert_eq!(lines, ["[WALK] <dining_room> (201)", "[WALK] <dishwasher> (1000)"]);
    assert_eq!(e.executed_lines(), ["[WALK] <dining_room> (201)", "[WALK] <dishwasher> (1000)"]);
    // Replays take the scene's ids, and their observations show them.
    let mut any = VirtualhomeEnv::new(task, "virtualhome-eai").with_id_scope(IdScope::Any);
    any.reset();
    assert!(any.step("[WALK] <dishwasher> (1000)").event.executed());
    assert!(any.unmet_goals().iter().any(|g| g.contains("(1000)")), "{:?}", any.unmet_goals());
}
