//! The agent on VirtualHome with the systematic explorer and A* (LM-cut) as Phase II on the
//! problem written from what it perceived: every task of the rearrangement set and every EAI
//! fixture task, each episode judged by `VirtualhomeEnv`'s goal check within the paper's 20 steps.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use exploration_harness::virtualhome::VirtualhomeAdapter;
use heuristics::search::Clock;
mod common;

use common::{Restless, assert_ends_where_the_engine_does, assert_no_target_repeats};
use exploration_harness::{Attribution, Episode, EpisodeConfig, Grounded, Ontology, PhaseTwo, Systematic, parse_goal, run_episode};
use household_sim::{Environment, IdScope, ScriptLine, VirtualhomeEnv, VirtualhomeTask};

/// A* expansions per plan: a bound that holds on any machine under any load (not a time limit).
const EXPANSIONS: u64 = 300_000;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

fn ontology() -> Ontology {
    Ontology::from_text(&std::fs::read_to_string(fixtures().join("ontology/virtualhome.txt")).unwrap(), "virtualhome.txt").unwrap()
}

/// One episode; with it, every plan Phase II returned checked against the transition model of
/// the grounded problem it came from (valid by construction: a failure here is a bug).
fn play(path: &Path, benchmark: &str, ontology: &Ontology) -> Episode {
    let config = EpisodeConfig { reexplore: true, ..EpisodeConfig::open_loop(20) };
    play_task_with(VirtualhomeTask::load(path).unwrap(), path, benchmark, ontology, config)
}

/// A* with LM-cut within [`EXPANSIONS`], no plan longer than the steps left (the sound domain
/// has unit costs, so none longer could finish), its `OverBound` checked as the agent's is
/// (`bounded_plan`); `Err` is the status of a search without a plan.
/// Over states up to interchangeable objects (`SearchConfig::symmetries`, optimal as well): in
/// 783_1 five plates go in the dishwasher, and A* without it took 100 s of this test's 104.
fn a_star(g: &Grounded) -> Result<Vec<grounding::ActionId>, String> {
    let mut config = heuristics::search::SearchConfig::new(heuristics::search::Algorithm::AStar);
    config.symmetries = true;
    config.max_expansions = Some(EXPANSIONS);
    config.max_cost = Some(g.steps_left as u64);
    heuristics::search::bounded_plan(&g.model, &config).map_err(|status| format!("{status:?}"))
}

/// `class (id)` as the agent is shown the scene's node `scene_id` of `task` (the environment's
/// ids are not the scene's: `household_sim::VirtualhomeEnv`, **Ids**).
fn shown(task: &VirtualhomeTask, class: &str, scene_id: u32) -> String {
    let id = VirtualhomeEnv::new(task.clone(), "virtualhome-eai").shown_id(scene_id).expect("a node of the scene");
    format!("{class} ({id})")
}

/// `line`, a script line the agent sent, with the scene's ids, as the engine is given it.
fn with_scene_ids(task: &VirtualhomeTask, line: &str) -> String {
    let env = VirtualhomeEnv::new(task.clone(), "virtualhome-eai");
    let g = &task.init.graph;
    let scene: BTreeMap<u32, u32> = g.indices().map(|ix| (env.shown_id(g.node(ix).id).unwrap(), g.node(ix).id)).collect();
    ScriptLine::parse(line).expect("a script line").map_ids(|id| scene.get(&id).copied()).to_string()
}

fn play_task(task: VirtualhomeTask, path: &Path, benchmark: &str, ontology: &Ontology) -> Episode {
    play_task_with(task, path, benchmark, ontology, EpisodeConfig::open_loop(20))
}

fn play_task_with(task: VirtualhomeTask, path: &Path, benchmark: &str, ontology: &Ontology, config: EpisodeConfig) -> Episode {
    let mut env = VirtualhomeEnv::new(task, benchmark);
    let goal = parse_goal(env.goal()).unwrap();
    let mut adapter = VirtualhomeAdapter::new(ontology.clone()).unwrap();
    let mut planner = |g: &Grounded| {
        let plan = match a_star(g) {
            Ok(plan) => plan,
            Err(why) => return Ok(PhaseTwo { no_plan: Some(why), ..PhaseTwo::default() }),
        };
        assert!(g.model.validate(&plan).is_ok(), "{}: plan invalid for its grounded problem", path.display());
        Ok(PhaseTwo { actions: plan, ..PhaseTwo::default() })
    };
    run_episode(&mut env, &mut adapter, &mut Systematic, &goal, config, &mut planner).expect("the run goes on")
}

fn tasks(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.to_string_lossy().ends_with(".json.gz")).collect();
    out.sort();
    out
}

/// (won, total, failures by attribution, failure lines)
fn play_set(dir: &Path, benchmark: &str) -> (usize, usize, BTreeMap<String, usize>, Vec<String>) {
    let ontology = ontology();
    let paths = tasks(dir);
    let (mut won, mut by, mut lines) = (0, BTreeMap::new(), Vec::new());
    for path in &paths {
        let episode = play(path, benchmark, &ontology);
        assert!(episode.steps.len() <= 20, "{}: {} steps", path.display(), episode.steps.len());
        // What the real engine is given to replay the record: the very commands sent, Phase I's and
        // the plan's, with the scene's ids, each with the outcome it had here.
        let task = VirtualhomeTask::load(path).unwrap();
        let script: Vec<(&str, bool)> = episode.engine_script.iter().map(|l| (l.line.as_str(), l.executed)).collect();
        let sent: Vec<(String, bool)> = episode.steps.iter().map(|s| (with_scene_ids(&task, &s.command), s.executed)).collect();
        let sent: Vec<(&str, bool)> = sent.iter().map(|(c, e)| (c.as_str(), *e)).collect();
        assert_eq!(script, sent, "{}", path.display());
        let mut replay = VirtualhomeEnv::new(task, benchmark).with_id_scope(IdScope::Any);
        assert_ends_where_the_engine_does(&mut replay, &episode, &path.display().to_string());
        // Plans are executable by construction: a step the environment refuses from a state
        // Phase I got right would be a soundness bug of the hand-over.
        assert_ne!(episode.attribution, Some(Attribution::Grounding), "{}: {:?}", path.display(), episode.failure);
        assert_phase_one_never_refused(&episode, &path.display().to_string());
        if episode.success {
            won += 1;
        } else {
            *by.entry(format!("{:?}", episode.attribution)).or_insert(0) += 1;
            lines.push(format!(
                "{}: {:?} {:?} stop {} p {:?} r {:?} steps {}",
                path.file_name().unwrap().to_string_lossy(),
                episode.attribution,
                episode.failure,
                episode.phase1_stop,
                episode.precision,
                episode.recall,
                episode.steps.len()
            ));
        }
    }
    (won, paths.len(), by, lines)
}

#[test]
fn systematic_exploration_then_a_star_on_the_rearrangement_set() {
    let (won, total, by, lines) = play_set(&fixtures().join("virtualhome-rearrange"), "virtualhome-rearrange");
    eprintln!("rearrange: won {won}/{total} {by:?}\n{}", lines.join("\n"));
    assert_eq!(total, 200);
    // Measured 2026-12-01: 200/200.
    assert_eq!(won, total, "won {won}/{total}");
}

#[test]
fn systematic_exploration_then_a_star_on_eai_fixture_tasks() {
    let (won, total, by, lines) = play_set(&fixtures().join("virtualhome-eai/graphs"), "virtualhome-eai");
    eprintln!("eai: won {won}/{total} {by:?}\n{}", lines.join("\n"));
    // Measured 2026-12-03: 29/33 (26/33 before the rooms the task sentence names came first;
    // 11/33 before an instance already as the goal asks stopped counting, the containers the
    // goal names came first, and A* was bounded by the steps left). EAI's goals name node ids
    // while the agent is told classes: in 1083_2 and 392_2 the goal's pot is one of three in the
    // kitchen and the sentence cannot say which (2 `goal` failures); 2 `representation`: 826_1
    // has no plan within the steps left, and in 710_2 the budget runs out before the plate is seen.
    assert_eq!(total, 33);
    assert!(won >= 29, "won {won}/{total}");
}

/// EAI 446_2, "Go to kitchen, go to cupboard with dishes, grab dishes, walk to dining room,
/// find table, put dishes on table.": the scene has three tables (107 in the bedroom, 226 in the
/// dining room, 355 in the home office) and EAI's goal names the dining room's. The sentence
/// names the kitchen and the dining room, both `dining_room` by the benchmark's own names
/// (F_str), so Ready waits until that room is entered and β binds its table. Told the same goal
/// with a sentence that names the bedroom, the agent binds the bedroom's table, and the judge
/// says not won. (With no room named, the table is whichever the agent
/// perceived first, by the environment's ids, which say nothing of the goal.)
#[test]
fn the_rooms_the_task_sentence_names_decide_which_instance_is_meant() {
    let path = fixtures().join("virtualhome-eai/graphs/446_2.json.gz");
    let task = VirtualhomeTask::load(&path).unwrap();
    let table = |episode: &Episode| episode.handover.as_ref().and_then(|h| h.binding.get("table").cloned());

    let (dining_table, bedroom_table) = (shown(&task, "table", 226), shown(&task, "table", 107));
    let told = play_task(task.clone(), &path, "virtualhome-eai", &ontology());
    assert!(told.success, "{:?}; plan {:?}", told.failure, told.plan);
    assert_eq!(table(&told), Some(dining_table));

    let mut elsewhere = task;
    elsewhere.description = "Go to the bedroom and put the dishes on the table.".to_string();
    let elsewhere = play_task(elsewhere, &path, "virtualhome-eai", &ontology());
    assert!(!elsewhere.success, "plan {:?}", elsewhere.plan);
    assert_eq!(table(&elsewhere), Some(bedroom_table));
}

/// EAI 134_1, "watching TV from sofa": the scene has two televisions, the kitchen's (248, the
/// first the sweep sees) and the living room's (410, by the sofa), and EAI's goal names 410.
/// The sentence names no room but names the sofa, a class of context: Ready waits for a
/// television in a room where a sofa was seen (or for every room), and β binds it. Told only
/// "Watch TV.", the agent binds the first television it perceived and the judge says not won.
#[test]
fn the_objects_the_task_sentence_names_decide_which_instance_is_meant() {
    let path = fixtures().join("virtualhome-eai/graphs/1004_2.json.gz");
    let goal = serde_json::json!({"actions": ["LOOKAT|WATCH"], "goal": [
        {"id": 410, "class_name": "television", "state": "ON"},
        {"from_id": 65, "relation_type": "FACING", "to_id": 410}]});
    let television = |episode: &Episode| episode.handover.as_ref().and_then(|h| h.binding.get("television").cloned());

    let mut told = scene_1004_2_with_goal(goal.clone());
    let (by_the_sofa, kitchens) = (shown(&told, "television", 410), shown(&told, "television", 248));
    told.description = "watching TV from sofa".to_string();
    let told = play_task(told, &path, "virtualhome-eai", &ontology());
    assert!(told.success, "{:?}; plan {:?}", told.failure, told.plan);
    assert_eq!(television(&told), Some(by_the_sofa));

    let mut untold = scene_1004_2_with_goal(goal);
    untold.description = "Watch TV.".to_string();
    let untold = play_task(untold, &path, "virtualhome-eai", &ontology());
    assert!(!untold.success, "plan {:?}", untold.plan);
    assert_eq!(television(&untold), Some(kitchens));
}

/// EAI's scene of 1004_2 with `goal` as its `vh_goal`.
fn scene_1004_2_with_goal(goal: serde_json::Value) -> VirtualhomeTask {
    scene_1004_2_edited(|task| task["vh_goal"] = goal)
}

/// EAI's executor ends no episode (it judges the state at the end of a whole script), so the
/// goal holding already does not end Phase I: the agent explores until Ready, hands over the
/// state it perceived, and the plan from it is empty. (Until HARNESS_VERSION 15 Phase I stopped
/// at `goal` before its first step, on a bit of hidden state the agent never sees.)
#[test]
fn a_goal_that_holds_from_the_start_does_not_end_a_virtualhome_episode() {
    let task = scene_1004_2_with_goal(serde_json::json!({"actions": [], "goal": [{"id": 417, "class_name": "computer", "state": "OFF"}]}));
    let mut env = VirtualhomeEnv::new(task.clone(), "virtualhome-eai");
    env.reset();
    assert!(env.goal_reached() && !env.done(), "the goal holds and the engine has not ended the episode");
    let episode = play_task(task, Path::new("1004_2 edited"), "virtualhome-eai", &ontology());
    assert!(episode.success, "{:?}", episode.failure);
    assert_ne!(episode.phase1_stop, "goal");
    assert!(episode.phase1_steps > 0, "Phase I took no step");
    assert!(episode.plan.is_empty(), "plan {:?}", episode.plan);
}

/// EAI's scene of 1004_2 (its task file as JSON), edited.
fn scene_1004_2_edited(edit: impl FnOnce(&mut serde_json::Value)) -> VirtualhomeTask {
    let path = fixtures().join("virtualhome-eai/graphs/1004_2.json.gz");
    let mut text = String::new();
    std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(std::fs::File::open(&path).unwrap()), &mut text).unwrap();
    let mut task: serde_json::Value = serde_json::from_str(&text).unwrap();
    edit(&mut task);
    VirtualhomeTask::from_json(&task.to_string(), "1004_2 edited").unwrap()
}

/// EAI 120_1, "Go to the kitchen and living room and turn on the lights.": the scene's four
/// lights are off, and EAI's goal gives two of them (245 in the kitchen, 411 in the living room)
/// `ON` and `PLUGGED_IN`. At class level that is a node goal repeated, so G asks for two lights
/// (`light`, `light_2`; in the problem `light_1` and `light_2`); β binds one in each room the
/// sentence names, and the plan turns both on. (Read as one light, the agent turned on one and
/// the judge said not won.)
#[test]
fn a_repeated_node_goal_binds_and_changes_as_many_instances() {
    let path = fixtures().join("virtualhome-eai/graphs/1004_2.json.gz");
    let task = scene_1004_2_edited(|task| {
        for node in task["init_graph"]["nodes"].as_array_mut().unwrap() {
            if node["class_name"] == "light" {
                node["states"] = serde_json::json!(["PLUGGED_IN", "OFF", "CLEAN"]);
            }
        }
        task["vh_goal"] = serde_json::json!({"actions": [], "goal": [
            {"id": 245, "class_name": "light", "state": "ON"}, {"id": 245, "class_name": "light", "state": "PLUGGED_IN"},
            {"id": 411, "class_name": "light", "state": "ON"}, {"id": 411, "class_name": "light", "state": "PLUGGED_IN"}]});
        task["description"] = "Go to the kitchen and living room and turn on the lights.".into();
    });
    let expected = BTreeSet::from([shown(&task, "light", 245), shown(&task, "light", 411)]);
    let episode = play_task(task, &path, "virtualhome-eai", &ontology());
    assert!(episode.success, "{:?}; plan {:?}", episode.failure, episode.plan);
    let binding = &episode.handover.as_ref().unwrap().binding;
    let lights: BTreeSet<String> = binding.values().filter(|v| v.starts_with("light (")).cloned().collect();
    assert_eq!(lights, expected, "{binding:?}");
    let switched = episode.steps.iter().filter(|s| s.command.starts_with("[SWITCHON] <light>")).count();
    assert_eq!(switched, 2, "{:?}", episode.steps);
}

/// An action goal (`LOOKAT|WATCH`) brings every perceived object that affords one of its verbs
/// into the problem, unless an object G binds already does: "watch the television" needs the
/// television, not the scene's sixteen drawings (in EAI 188_1 every movable object of the scene
/// grounded a million actions and no plan was found in 60 s).
#[test]
fn an_action_goal_an_object_of_the_goal_affords_adds_no_other_objects() {
    let path = fixtures().join("virtualhome-eai/graphs/1004_2.json.gz");
    let objects =
        |episode: &Episode| -> Vec<String> { episode.handover.as_ref().map(|h| h.binding.values().cloned().collect()).unwrap_or_default() };
    // The kitchen's television (248): the sentence names the kitchen.
    let watch = scene_1004_2_with_goal(serde_json::json!({"actions": ["LOOKAT|WATCH"], "goal": [
        {"id": 248, "class_name": "television", "state": "ON"},
        {"from_id": 65, "relation_type": "FACING", "to_id": 248}]}));
    let episode = play_task(watch, &path, "virtualhome-eai", &ontology());
    assert!(episode.success, "{:?}; plan {:?}", episode.failure, episode.plan);
    assert!(!objects(&episode).iter().any(|x| x.starts_with("drawing")), "{:?}", objects(&episode));

    // Told only to look at something, the agent may look at anything lookable it saw (and never
    // at a goal step or kind constant of the domain, which are PDDL objects too: a plan turned
    // to `k_grab` here before the sound domain's turn_to excluded them).
    let look = scene_1004_2_with_goal(serde_json::json!({"actions": ["LOOKAT|WATCH"], "goal": []}));
    let episode = play_task(look, &path, "virtualhome-eai", &ontology());
    assert!(episode.success, "{:?}; plan {:?}", episode.failure, episode.plan);
    assert!(objects(&episode).iter().any(|x| x.starts_with("drawing")), "{:?}", objects(&episode));
}

/// EAI's scene of 1004_2 with computer 170 (the bedroom's, the first the sweep finds) in
/// `states`, and the goal: computer 417 (the home office's, off) on; and the task's path.
fn scene_1004_2_with_computer_170(states: &[&str]) -> (VirtualhomeTask, PathBuf) {
    let path = fixtures().join("virtualhome-eai/graphs/1004_2.json.gz");
    let mut text = String::new();
    std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(std::fs::File::open(&path).unwrap()), &mut text).unwrap();
    let mut task: serde_json::Value = serde_json::from_str(&text).unwrap();
    for node in task["init_graph"]["nodes"].as_array_mut().unwrap() {
        if node["id"] == 170 {
            node["states"] = serde_json::json!(states);
        }
    }
    task["vh_goal"] = serde_json::json!({"actions": [], "goal": [{"id": 417, "class_name": "computer", "state": "ON"}]});
    (VirtualhomeTask::from_json(&task.to_string(), "1004_2 with computer 417 to turn on").unwrap(), path)
}

/// A task asks for a change: when the first computer the agent sees is already on, "turn on
/// the computer" (EAI's goal names the other one, as in EAI task 101_2) is not about it, so
/// Phase I looks on, and β binds the computer that is off. Before this rule the agent stopped at
/// once with an empty plan and the judge said not won.
#[test]
fn an_instance_already_as_the_goal_asks_is_not_the_one_the_task_means() {
    // Computer 170 (the bedroom's) on; the goal: computer 417 (the home office's, off) on.
    let (task, path) = scene_1004_2_with_computer_170(&["PLUGGED_IN", "ON", "CLEAN"]);
    let (on, off) = (shown(&task, "computer", 170), shown(&task, "computer", 417));
    let episode = play_task(task, &path, "virtualhome-eai", &ontology());
    let explored: Vec<&str> = episode.steps.iter().filter(|s| s.phase == "explore").map(|s| s.command.as_str()).collect();
    assert!(episode.success, "{:?}; explored {explored:?}; plan {:?}", episode.failure, episode.plan);
    assert!(episode.plan.iter().any(|c| c.contains(&format!("<{}", off.replace(" (", "> (")))), "plan {:?}", episode.plan);
    assert!(!episode.plan.iter().any(|c| c.contains(&format!("<{}", on.replace(" (", "> (")))), "plan {:?}", episode.plan);
}

/// EAI's scenes 1004_2 and 819_1: the first computer the sweep finds (170, the bedroom's) is
/// unplugged and has no plug, so "turn on the computer" cannot be met with it; EAI's goal names
/// the home office's (417). The paper's episode hands over at the first Ready and Phase II
/// meets a dead end; with `reexplore`, the hand-over's goal fact `(on computer)` is one
/// grounding never reaches, so computer 170 is set aside, Phase I goes on to the next room, and
/// the plan turns on computer 417.
#[test]
fn an_instance_that_cannot_meet_the_goal_is_set_aside_and_phase_one_goes_on() {
    let task = || scene_1004_2_with_computer_170(&["PLUGGED_OUT", "OFF", "CLEAN"]).0;
    let path = fixtures().join("virtualhome-eai/graphs/1004_2.json.gz");
    let (unplugged, office) = (shown(&task(), "computer", 170), shown(&task(), "computer", 417));

    let paper = play_task_with(task(), &path, "virtualhome-eai", &ontology(), EpisodeConfig::open_loop(20));
    assert!(!paper.success);
    assert!(paper.no_plan, "{:?}", paper.failure);
    assert_eq!(paper.handovers, 1);
    assert!(paper.set_aside.is_empty());
    assert_eq!(paper.handover.as_ref().unwrap().binding.get("computer"), Some(&unplugged));

    let config = EpisodeConfig { reexplore: true, ..EpisodeConfig::open_loop(20) };
    let episode = play_task_with(task(), &path, "virtualhome-eai", &ontology(), config);
    let explored: Vec<&str> = episode.steps.iter().filter(|s| s.phase == "explore").map(|s| s.command.as_str()).collect();
    assert!(episode.success, "{:?}; explored {explored:?}; plan {:?}", episode.failure, episode.plan);
    assert_eq!(episode.set_aside, [unplugged]);
    assert_eq!(episode.handovers, 2);
    assert!(episode.phase1_steps > paper.phase1_steps, "Phase I went on: {} then {}", paper.phase1_steps, episode.phase1_steps);
    assert_eq!(episode.phase1_steps, explored.len());
    assert!(episode.steps.len() <= 20);
    assert!(episode.plan.iter().any(|c| c.contains(&format!("<{}", office.replace(" (", "> (")))), "plan {:?}", episode.plan);
}

/// K_t never offers a way to circle: whatever a policy picks, no `goto`, `open` or `close` of
/// Phase I targets the same object twice (SmolLM2 walked between two closed containers for all
/// 20 steps when a visited one was offered again), so a wandering policy keeps finding new
/// places until Ready or the budget.
#[test]
fn no_phase_one_skill_of_the_controller_repeats_a_target() {
    let ontology = ontology();
    for (i, path) in tasks(&fixtures().join("virtualhome-rearrange")).iter().step_by(10).enumerate() {
        let mut env = VirtualhomeEnv::new(VirtualhomeTask::load(path).unwrap(), "virtualhome-rearrange");
        let goal = parse_goal(env.goal()).unwrap();
        let mut adapter = VirtualhomeAdapter::new(ontology.clone()).unwrap();
        let mut policy = Restless::new(1 + i % 3, i % 2 == 1);
        let mut planner = |_: &Grounded| {
            Ok::<PhaseTwo, exploration_harness::RunError>(PhaseTwo { no_plan: Some("no Phase II here".into()), ..PhaseTwo::default() })
        };
        let episode =
            run_episode(&mut env, &mut adapter, &mut policy, &goal, EpisodeConfig::open_loop(60), &mut planner).expect("the run goes on");
        assert_no_target_repeats(&episode, &path.display().to_string());
        assert_phase_one_never_refused(&episode, &path.display().to_string());
    }
}

/// K_t offers only what the executor accepts from what was perceived: no Phase I command is
/// refused. (The sweep walked to the rearrangement set's fridge-043 freezer, which is on, and
/// tried to open it; EAI's executor refuses that, "is still on", and so does ours.)
fn assert_phase_one_never_refused(episode: &Episode, what: &str) {
    for s in episode.steps.iter().filter(|s| s.phase == "explore") {
        assert!(s.executed, "{what}: Phase I's {} was refused: {}", s.command, s.observation);
    }
}

/// When exploration takes every step of the budget, no Phase II runs and the failure is
/// Phase I's (`representation`), even with F_τ right: it was the exploration that left no step
/// for a plan. The budget here is exactly the steps the sweep takes to Ready.
#[test]
fn phase_one_spending_the_budget_is_an_exploration_failure() {
    let path = &tasks(&fixtures().join("virtualhome-rearrange"))[0];
    let run = |budget: usize| {
        let mut env = VirtualhomeEnv::new(VirtualhomeTask::load(path).unwrap(), "virtualhome-rearrange");
        let goal = parse_goal(env.goal()).unwrap();
        let mut adapter = VirtualhomeAdapter::new(ontology()).unwrap();
        let called = std::cell::Cell::new(false);
        let mut planner = |_: &Grounded| {
            called.set(true);
            Ok::<PhaseTwo, exploration_harness::RunError>(PhaseTwo { no_plan: Some("no plan here".into()), ..PhaseTwo::default() })
        };
        let episode = run_episode(&mut env, &mut adapter, &mut Systematic, &goal, EpisodeConfig::open_loop(budget), &mut planner)
            .expect("the run goes on");
        (episode, called.get())
    };
    let (first, _) = run(20);
    assert_eq!(first.phase1_stop, "ready");
    let k = first.phase1_steps;
    assert!(k > 0);
    let (episode, called) = run(k);
    assert_eq!((episode.phase1_stop.as_str(), episode.phase1_steps), ("ready", k));
    assert_eq!((episode.precision, episode.recall), (Some(1.0), Some(1.0)));
    assert!(!called && !episode.success);
    assert_eq!(episode.failure.as_deref(), Some("step budget spent before Phase II"));
    assert_eq!(episode.attribution, Some(Attribution::Representation));
    // One step left, fewer than the optimal plan of ŝ0 needs: Phase II finds no plan, and A*
    // proves that none fits, so exploration spent the steps.
    let mut env = VirtualhomeEnv::new(VirtualhomeTask::load(path).unwrap(), "virtualhome-rearrange");
    let goal = parse_goal(env.goal()).unwrap();
    let mut adapter = VirtualhomeAdapter::new(ontology()).unwrap();
    let optimal = std::cell::Cell::new(0);
    let mut planner = |g: &Grounded| {
        optimal.set(heuristics::search::optimal_plan_expanding(&g.model, EXPANSIONS).map_or(0, |p| p.len()));
        Ok(PhaseTwo { no_plan: Some("exhausted".into()), ..PhaseTwo::default() })
    };
    let episode = run_episode(&mut env, &mut adapter, &mut Systematic, &goal, EpisodeConfig::open_loop(k + 1), &mut planner)
        .expect("the run goes on");
    assert!(optimal.get() > 1, "the optimal plan takes {} steps", optimal.get());
    assert_eq!((episode.precision, episode.recall), (Some(1.0), Some(1.0)));
    assert_eq!(episode.attribution, Some(Attribution::Representation), "{:?}", episode.failure);
}

/// `plan_fit` on EAI 229_1's hand-over (coffee: the sweep's Phase I takes 4 steps, the optimal
/// plan 8, LM-cut at ŝ0 says 7): LM-cut alone cannot tell that 7 steps are too few; A* within
/// 7 proves it, within 8 finds the plan, and with one expansion proves nothing.
#[test]
fn a_star_within_the_steps_left_proves_that_no_plan_fits_where_lm_cut_cannot() {
    use exploration_harness::{PlanFit, plan_fit};
    use heuristics::Heuristic;
    let path = fixtures().join("virtualhome-eai/graphs/229_1.json.gz");
    let mut env = VirtualhomeEnv::new(VirtualhomeTask::load(&path).unwrap(), "virtualhome-eai");
    let goal = parse_goal(env.goal()).unwrap();
    let mut adapter = VirtualhomeAdapter::new(ontology()).unwrap();
    let fits = std::cell::RefCell::new(Vec::new());
    let mut planner = |g: &Grounded| {
        let lm_cut = heuristics::LmCut::new(&g.model).evaluate(&g.model.initial_state());
        fits.borrow_mut().push((
            lm_cut,
            plan_fit(&g.model, 7, 200_000, None, Clock::Wall),
            plan_fit(&g.model, 8, 200_000, None, Clock::Wall),
            plan_fit(&g.model, 7, 1, None, Clock::Wall),
        ));
        Ok(PhaseTwo { actions: a_star(g).expect("A* plans the hand-over"), ..PhaseTwo::default() })
    };
    let episode =
        run_episode(&mut env, &mut adapter, &mut Systematic, &goal, EpisodeConfig::open_loop(20), &mut planner).expect("the run goes on");
    assert!(episode.success, "{:?}", episode.failure);
    assert_eq!(episode.plan.len(), 8);
    assert_eq!(fits.into_inner(), vec![(Some(7), PlanFit::NoneFits, PlanFit::Fits(8), PlanFit::Unknown)]);
}

/// A search that ends without a plan still counts: its model calls, tokens and detail are in
/// the record, and the failure is Phase II's (`search`) when Phase I's state was right. The
/// planner is told how many steps the plan may take.
#[test]
fn a_phase_two_without_a_plan_keeps_its_usage_and_was_told_the_steps_left() {
    let path = &tasks(&fixtures().join("virtualhome-rearrange"))[0];
    let mut env = VirtualhomeEnv::new(VirtualhomeTask::load(path).unwrap(), "virtualhome-rearrange");
    let goal = parse_goal(env.goal()).unwrap();
    let mut adapter = VirtualhomeAdapter::new(ontology()).unwrap();
    let steps_left = std::cell::Cell::new(None);
    let mut planner = |g: &Grounded| {
        steps_left.set(Some(g.steps_left));
        Ok(PhaseTwo {
            model_calls: 7,
            generated_tokens: 5,
            detail: serde_json::json!({"stop": "wall-clock"}),
            no_plan: Some("wall-clock".into()),
            ..PhaseTwo::default()
        })
    };
    let episode =
        run_episode(&mut env, &mut adapter, &mut Systematic, &goal, EpisodeConfig::open_loop(20), &mut planner).expect("the run goes on");
    assert!(!episode.success);
    assert_eq!((episode.phase2_calls, episode.phase2_tokens), (7, 5));
    assert_eq!(episode.phase2_detail["stop"], "wall-clock");
    assert_eq!(episode.failure.as_deref(), Some("no plan: wall-clock"));
    assert!(episode.plan.is_empty());
    assert_eq!(episode.attribution, Some(Attribution::Search), "{:?} {:?}", episode.precision, episode.recall);
    // N_plan = N − N_exp: the planner was told the steps Phase I left.
    assert_eq!(steps_left.get(), Some(20 - episode.phase1_steps));
}

/// A plan that goes on with a step that cannot be grounded (an unconstrained decoder's) ends
/// there: the applicable prefix is sent, then the episode fails at grounding.
#[test]
fn a_plan_step_that_cannot_be_grounded_ends_the_episode_at_grounding() {
    let path = &tasks(&fixtures().join("virtualhome-rearrange"))[0];
    let mut env = VirtualhomeEnv::new(VirtualhomeTask::load(path).unwrap(), "virtualhome-rearrange");
    let goal = parse_goal(env.goal()).unwrap();
    let mut adapter = VirtualhomeAdapter::new(ontology()).unwrap();
    let mut planner = |g: &Grounded| {
        let plan = match a_star(g) {
            Ok(plan) => plan,
            Err(why) => return Ok(PhaseTwo { no_plan: Some(why), ..PhaseTwo::default() }),
        };
        Ok(PhaseTwo { actions: plan[..1].to_vec(), invalid_step: Some("walk to the moon".into()), ..PhaseTwo::default() })
    };
    let episode =
        run_episode(&mut env, &mut adapter, &mut Systematic, &goal, EpisodeConfig::open_loop(20), &mut planner).expect("the run goes on");
    assert!(!episode.success && episode.plan_invalid && !episode.no_plan);
    assert_eq!(episode.plan.len(), 1);
    assert_eq!(episode.failure.as_deref(), Some("plan step 2 cannot be grounded: walk to the moon"));
    assert_eq!(episode.attribution, Some(Attribution::Grounding));
}

/// The same task gives the same episode.
#[test]
fn virtualhome_episodes_are_reproducible() {
    let ontology = ontology();
    for path in tasks(&fixtures().join("virtualhome-rearrange")).iter().step_by(25) {
        let (a, b) = (play(path, "virtualhome-rearrange", &ontology), play(path, "virtualhome-rearrange", &ontology));
        assert_eq!(a.steps, b.steps, "{}", path.display());
        assert_eq!(a.handover, b.handover, "{}", path.display());
    }
}

/// Every fact VirtualHome's perceiver reads off an observation (but the character's own, whose
/// id the agent never sees) is true in the hidden state at that step, checked through the judge,
/// along every rearrangement task's reference program and EAI fixture tasks' first steps.
#[test]
fn every_virtualhome_percept_holds_in_the_hidden_state() {
    use exploration_harness::virtualhome::{ME, perceive_virtualhome};
    use exploration_harness::{Belief, Fact};
    use household_sim::Judge;
    let judged = |fact: &Fact, atoms: &std::collections::BTreeSet<(String, Vec<String>)>| {
        atoms.contains(&(fact.predicate.clone(), fact.args.clone())) == fact.holds
    };
    let mut checked = 0;
    for path in tasks(&fixtures().join("virtualhome-rearrange")) {
        let task = VirtualhomeTask::load(&path).unwrap();
        let program = task.reference_program.clone();
        let mut env = VirtualhomeEnv::new(task, "virtualhome-rearrange").with_id_scope(IdScope::Any);
        let mut belief = Belief::default();
        let mut text = env.reset().text;
        for step in 0..=program.len() {
            let atoms = env.hidden_atoms().into_iter().map(|a| (a.predicate, a.args)).collect();
            let (rooms, percepts) = perceive_virtualhome(&text, step, &belief);
            assert!(!rooms.is_empty(), "{}: no rooms read", path.display());
            for p in percepts.iter().filter(|p| p.fact.args[0] != ME) {
                assert!(judged(&p.fact, &atoms), "{} step {step}: {} is not what the hidden state says", path.display(), p.fact);
                checked += 1;
            }
            belief.admit(&percepts);
            if step < program.len() {
                text = env.step(&program[step]).observation.text;
            }
        }
    }
    assert!(checked > 100_000, "{checked}");
}

/// `Episode::budget_spent` (Table 11's interaction limit): EAI 201_1 with one step, where the
/// dishwasher is in another room than the one the character starts in: Phase I spends the step
/// and cannot hand over a state with the dishwasher in it, so the budget ended the episode.
/// With the paper's 20 steps the agent wins, and the flag stays down.
#[test]
fn the_budget_ends_an_episode_only_where_it_cuts_it_short() {
    let path = fixtures().join("virtualhome-eai/graphs/201_1.json.gz");
    let task = VirtualhomeTask::load(&path).unwrap();
    let short = play_task_with(task.clone(), &path, "virtualhome-eai", &ontology(), EpisodeConfig::open_loop(1));
    assert!(!short.success);
    assert_eq!((short.phase1_stop.as_str(), short.steps.len()), ("budget", 1), "{:?}", short.failure);
    assert!(short.budget_spent, "{:?}", short.failure);
    let whole = play_task(task, &path, "virtualhome-eai", &ontology());
    assert!(whole.success && !whole.budget_spent, "{:?}", whole.failure);
    // EAI 1004_2 ("put groceries in the fridge"): the agent puts a food in the freezer, not the
    // one the judge checks, and loses on `goal`. Given exactly the steps it took, its plan is
    // sent whole on the last one: the agent ended the episode, not the budget.
    let path = fixtures().join("virtualhome-eai/graphs/1004_2.json.gz");
    let task = VirtualhomeTask::load(&path).unwrap();
    let lost = play_task(task.clone(), &path, "virtualhome-eai", &ontology());
    assert!(!lost.success && !lost.plan.is_empty() && !lost.budget_spent, "{:?} {:?}", lost.failure, lost.plan);
    let budget = lost.steps.len();
    let exact = play_task_with(task, &path, "virtualhome-eai", &ontology(), EpisodeConfig::open_loop(budget));
    assert_eq!((exact.success, exact.steps.len(), &exact.plan), (false, budget, &lost.plan), "{:?}", exact.failure);
    assert_eq!(exact.attribution, Some(Attribution::Goal));
    assert!(!exact.budget_spent, "{:?}", exact.failure);
}
