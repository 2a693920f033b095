//! f_φ through the chat interface, with a scripted chat model standing in for a served one:
//! the request carries the paper's Phase I sections and the reply schema (the valid skills as an
//! enum); the policy's choice is followed; the facts it proposes never enter F_t unless an
//! observation states them.

use std::path::{Path, PathBuf};

use exploration_harness::alfworld::AlfworldAdapter;
use exploration_harness::chat_policy::ChatPolicy;
use exploration_harness::{EpisodeConfig, Grounded, Ontology, PhaseTwo, parse_goal, run_episode};
use household_sim::{AlfworldEnv, Environment};
use vlm_client::{ChatError, ChatModel, ChatReply, ChatRequest, Usage};

/// A reply of `text`, one request's usage.
fn reply(text: String, usage: &mut Usage) -> Result<ChatReply, ChatError> {
    let one = Usage { requests: 1, prompt_tokens: 100, completion_tokens: 20, reasoning_tokens: None, images: 0 };
    usage.add(&one);
    Ok(ChatReply::local(text, one))
}

/// Answers every request with the first valid skill and a made-up fact.
struct Scripted {
    usage: Usage,
    prompts: Vec<String>,
}

impl ChatModel for Scripted {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        let schema = request.json_schema.as_ref().expect("a reply schema");
        let first = schema["properties"]["action"]["enum"][0].as_str().unwrap().to_string();
        self.prompts.push(request.messages.iter().map(|m| m.joined_text()).collect::<Vec<_>>().join("\n"));
        let text = serde_json::json!({"facts": ["inReceptacle(mug 99, fridge 1)"], "action": first, "done": false}).to_string();
        reply(text, &mut self.usage)
    }

    fn endpoint(&self) -> String {
        "scripted".into()
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}

/// A* expansions per plan: a bound that holds on any machine under any load (not a time limit).
const EXPANSIONS: u64 = 1_000_000;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// What an ALFWorld adapter is built from: F_str, the domain and the command grammar.
fn alfworld_parts() -> (Ontology, pddl_syntax::Domain, String) {
    let ontology =
        Ontology::from_text(&std::fs::read_to_string(fixtures().join("ontology/alfworld.txt")).unwrap(), "alfworld.txt").unwrap();
    let domain = pddl_syntax::parse_domain(&std::fs::read_to_string(fixtures().join("alfworld/alfred.pddl")).unwrap()).unwrap();
    let grammar = std::fs::read_to_string(fixtures().join("alfworld/alfred.twl2")).unwrap();
    (ontology, domain, grammar)
}

#[test]
fn a_chat_policy_explores_and_its_proposals_stay_hypotheses() {
    let (ontology, domain, grammar) = alfworld_parts();
    let root = fixtures().join("alfworld/valid_seen");
    let mut families: Vec<PathBuf> = std::fs::read_dir(&root).unwrap().map(|f| f.unwrap().path()).collect();
    families.sort();
    let mut won = 0;
    // One policy for every game, as `cargo xtask eval` keeps one: each episode's usage is its own.
    let mut policy = ChatPolicy::new(Box::new(Scripted { usage: Usage::default(), prompts: Vec::new() }), "scripted");
    for family in families.iter().step_by(7) {
        let game = std::fs::read_dir(family).unwrap().next().unwrap().unwrap().path().join("game.tw-pddl");
        let mut env = AlfworldEnv::from_game_file(&game).unwrap();
        let goal = parse_goal(env.goal()).unwrap();
        let mut adapter = AlfworldAdapter::new(ontology.clone(), domain.clone(), grammar.clone(), env.goal());
        let mut planner = |g: &Grounded| {
            heuristics::search::optimal_plan_expanding(&g.model, EXPANSIONS).map_or_else(
                |s| Ok(PhaseTwo { no_plan: Some(format!("{s:?}")), ..PhaseTwo::default() }),
                |actions| Ok(PhaseTwo { actions, ..PhaseTwo::default() }),
            )
        };
        let episode =
            run_episode(&mut env, &mut adapter, &mut policy, &goal, EpisodeConfig::open_loop(55), &mut planner).expect("the run goes on");
        won += usize::from(episode.success);
        let usage = episode.phase1_usage;
        assert_eq!(usage.calls as usize, episode.decisions.len() + usize::from(episode.phase1_stop == "done"), "{}", game.display());
        for d in &episode.decisions {
            assert!(d.offered.contains(&d.skill), "{}: {} not offered", game.display(), d.skill);
            assert!(d.refused.iter().any(|f| f == "inReceptacle(mug 99, fridge 1)"), "{}: {d:?}", game.display());
        }
        let prompt = &policy.last_prompt;
        for section in
            ["Task:", "Objects to find and locate:", "Current belief:", "Previous actions:", "Valid skills right now:", "Feedback:"]
        {
            assert!(usage.calls == 0 || prompt.contains(section), "{section} missing from {prompt}");
        }
        if let Some(h) = &episode.handover {
            assert!(!h.problem.contains("mug_99"), "{}: a proposed object reached ŝ0", game.display());
        }
    }
    assert!(won >= 1, "the scripted policy won {won} games");
}

/// The Phase I prompt of a game's first step, as the model reads it (the paper's sections).
#[test]
fn the_phase_one_prompt_of_a_first_step() {
    use exploration_harness::phase1::explore;
    let (ontology, domain, grammar) = alfworld_parts();
    let game = fixtures()
        .join("alfworld/valid_seen/pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802/game.tw-pddl");
    let mut env = AlfworldEnv::from_game_file(&game).unwrap();
    let goal = parse_goal(env.goal()).unwrap();
    let mut adapter = AlfworldAdapter::new(ontology, domain, grammar, env.goal());
    let mut policy = ChatPolicy::new(Box::new(Scripted { usage: Usage::default(), prompts: Vec::new() }), "scripted");
    let first = env.reset();
    let exploration = explore(&mut env, &mut adapter, &mut policy, &goal, &first, 2, None).expect("the run goes on");
    assert!(!exploration.record.steps.is_empty());
    insta::assert_snapshot!(policy.last_prompt);
}

/// Fails every request as `kind` says once `answered` good replies are spent.
struct Failing {
    kind: vlm_client::ChatErrorKind,
    answered: usize,
    inner: Scripted,
}

impl ChatModel for Failing {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        if self.answered == 0 {
            return Err(ChatError { kind: self.kind.clone(), url: "scripted".into(), attempts: 3, elapsed: Default::default() });
        }
        self.answered -= 1;
        self.inner.chat(request)
    }

    fn endpoint(&self) -> String {
        "failing".into()
    }

    fn usage(&self) -> Usage {
        self.inner.usage
    }
}

/// A model that cannot be asked (after the client's retries) stops Phase I with the run's
/// error, not a refusal the episode would keep; a reply that cannot be read is the model's
/// failure, refused, and exploration goes on.
#[test]
fn an_unreachable_model_stops_the_run_and_an_unreadable_reply_is_refused() {
    use exploration_harness::phase1::explore;
    use vlm_client::ChatErrorKind;
    let (ontology, domain, grammar) = alfworld_parts();
    let game = fixtures()
        .join("alfworld/valid_seen/pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802/game.tw-pddl");
    let run = |kind: ChatErrorKind| {
        let mut env = AlfworldEnv::from_game_file(&game).unwrap();
        let goal = parse_goal(env.goal()).unwrap();
        let mut adapter = AlfworldAdapter::new(ontology.clone(), domain.clone(), grammar.clone(), env.goal());
        let failing = Failing { kind, answered: 0, inner: Scripted { usage: Usage::default(), prompts: Vec::new() } };
        let mut policy = ChatPolicy::new(Box::new(failing), "failing");
        let first = env.reset();
        explore(&mut env, &mut adapter, &mut policy, &goal, &first, 10, None)
    };
    for kind in [
        ChatErrorKind::Timeout(std::time::Duration::from_secs(60)),
        ChatErrorKind::Status { status: 404, body: "no such model".into(), retry_after: None },
    ] {
        let error = run(kind.clone()).expect_err("the run stops");
        assert!(error.0.contains("unavailable"), "{kind:?}: {error}");
    }
    let unreadable = ChatErrorKind::InvalidJson { error: "expected an object".into(), reply: "go to the fridge".into() };
    let exploration = run(unreadable).expect("an unreadable reply is the model's failure");
    assert_eq!(exploration.record.decisions.iter().filter(|d| d.outcome == "error").count(), 3, "{:?}", exploration.record.decisions);
    assert_eq!(
        exploration.stop,
        "policy error: scripted: the reply is not the JSON asked for: expected an object; reply: go to the fridge (after 3 attempt(s), 0.0 s)"
    );
}

/// Answers in prose, except every `valid_every`-th request (never when 0), which the scripted
/// model answers; counts every request in `asked`.
struct Prose {
    valid_every: usize,
    asked: std::rc::Rc<std::cell::Cell<u64>>,
    inner: Scripted,
}

impl ChatModel for Prose {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        self.asked.set(self.asked.get() + 1);
        if self.valid_every > 0 && self.asked.get().is_multiple_of(self.valid_every as u64) {
            return self.inner.chat(request);
        }
        reply("I will look in the fridge first.".into(), &mut self.inner.usage)
    }

    fn endpoint(&self) -> String {
        "prose".into()
    }

    fn usage(&self) -> Usage {
        self.inner.usage
    }
}

/// Phase I counts what the model spent as the direct policy counts it: every request, a repair
/// turn and a reply that could not be read included, with their tokens.
#[test]
fn phase_one_counts_every_request_a_repair_and_an_unreadable_reply_included() {
    use exploration_harness::Policy;
    use exploration_harness::phase1::explore;
    let (ontology, domain, grammar) = alfworld_parts();
    let game = fixtures()
        .join("alfworld/valid_seen/pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802/game.tw-pddl");
    // Every first answer prose and every repair read (two calls a decision), then none read.
    for valid_every in [2, 0] {
        let asked = std::rc::Rc::new(std::cell::Cell::new(0));
        let model = Prose { valid_every, asked: asked.clone(), inner: Scripted { usage: Usage::default(), prompts: Vec::new() } };
        let mut policy = ChatPolicy::new(Box::new(model), "prose");
        let mut env = AlfworldEnv::from_game_file(&game).unwrap();
        let goal = parse_goal(env.goal()).unwrap();
        let mut adapter = AlfworldAdapter::new(ontology.clone(), domain.clone(), grammar.clone(), env.goal());
        let first = env.reset();
        let exploration = explore(&mut env, &mut adapter, &mut policy, &goal, &first, 10, None).expect("the run goes on");
        let usage = policy.usage();
        let decisions = exploration.record.decisions.len() as u64;
        assert!(asked.get() >= 2 && asked.get().is_multiple_of(2), "{valid_every}: {} requests", asked.get());
        assert_eq!(usage.calls, asked.get(), "{valid_every}: {:?}", exploration.record.decisions);
        assert_eq!((usage.prompt_tokens, usage.generated_tokens), (100 * asked.get(), 20 * asked.get()), "{valid_every}");
        let errors = exploration.record.decisions.iter().filter(|d| d.outcome == "error").count() as u64;
        if valid_every == 0 {
            assert_eq!(errors, decisions, "no reply was read");
        } else {
            assert_eq!(errors, 0, "every repair was read");
        }
    }
}

/// Proposes random facts (over names from the prompt and made-up ones) and a random valid skill.
struct Random {
    rng: household_sim::PythonRandom,
    usage: Usage,
}

impl ChatModel for Random {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        let schema = request.json_schema.as_ref().expect("a reply schema");
        let skills: Vec<&str> = schema["properties"]["action"]["enum"].as_array().unwrap().iter().filter_map(|v| v.as_str()).collect();
        let skill = skills[self.rng.choice_index(skills.len())];
        let names = ["mug 1", "mug 7", "fridge 1", "countertop 1", "apple 3", "cabinet 2", "nowhere 9"];
        let predicates = ["inReceptacle", "opened", "holds", "isHot", "visited"];
        let mut facts = Vec::new();
        for _ in 0..self.rng.choice_index(5) {
            let p = predicates[self.rng.choice_index(predicates.len())];
            let (a, b) = (names[self.rng.choice_index(names.len())], names[self.rng.choice_index(names.len())]);
            let negated = if self.rng.choice_index(4) == 0 { "not " } else { "" };
            facts.push(if p == "inReceptacle" { format!("{negated}{p}({a}, {b})") } else { format!("{negated}{p}({a})") });
        }
        let done = self.rng.choice_index(10) == 0;
        let text = serde_json::json!({"facts": facts, "action": skill, "done": done}).to_string();
        reply(text, &mut self.usage)
    }

    fn endpoint(&self) -> String {
        "random".into()
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        cases: 12,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..proptest::prelude::ProptestConfig::default()
    })]

    /// Whatever a policy proposes, F_τ is exactly what U makes of the environment's observations
    /// alone: replaying the episode's observations into an empty belief gives the same facts.
    /// With a frontier, no decision is offered more `goto` skills than it allows.
    #[test]
    fn proposals_never_change_what_phase_one_establishes(
        seed in 0u64..10_000,
        game in 0usize..140,
        frontier in proptest::option::of((1usize..4, proptest::bool::ANY)),
    ) {
        use exploration_harness::phase1::{Adapter, explore};
        let (ontology, domain, grammar) = alfworld_parts();
        let mut games = Vec::new();
        for family in std::fs::read_dir(fixtures().join("alfworld/valid_seen")).unwrap() {
            for trial in std::fs::read_dir(family.unwrap().path()).unwrap() {
                games.push(trial.unwrap().path().join("game.tw-pddl"));
            }
        }
        games.sort();
        let mut env = AlfworldEnv::from_game_file(&games[game]).unwrap();
        let goal = parse_goal(env.goal()).unwrap();
        let mut adapter = AlfworldAdapter::new(ontology.clone(), domain.clone(), grammar.clone(), env.goal());
        let mut policy = ChatPolicy::new(Box::new(Random { rng: household_sim::PythonRandom::new(seed), usage: Usage::default() }), "random");
        let first = env.reset();
        let frontier = frontier.map(|(width, narrowing)| exploration_harness::Frontier { width, narrowing });
        let exploration = explore(&mut env, &mut adapter, &mut policy, &goal, &first, 30, frontier).expect("the run goes on");
        for decision in &exploration.record.decisions {
            let gotos = decision.offered.iter().filter(|s| s.starts_with("goto ")).count();
            proptest::prop_assert!(gotos <= frontier.map_or(usize::MAX, |f| f.width), "{:?} offered {gotos} places", frontier);
        }
        let mut replay = exploration_harness::Belief::default();
        let mut fresh = AlfworldAdapter::new(ontology, domain, grammar, env.goal());
        fresh.observe(&first, 0, &mut replay);
        for (i, step) in exploration.record.steps.iter().enumerate() {
            fresh.observe(&household_sim::Observation::text(step.observation.clone()), i + 1, &mut replay);
        }
        proptest::prop_assert_eq!(exploration.belief.facts(), replay.facts());
    }
}

/// Always takes the last `goto` skill it is offered: a model that keeps passing over the
/// controller's first place.
struct LastPlace;

impl exploration_harness::Policy for LastPlace {
    fn name(&self) -> String {
        "last-place".into()
    }

    fn choose(
        &mut self,
        input: &exploration_harness::phase1::PolicyInput<'_>,
    ) -> Result<exploration_harness::phase1::PolicyReply, exploration_harness::PolicyError> {
        use exploration_harness::Skill;
        let skill = input.skills.list.iter().rev().find(|s| matches!(s, Skill::Goto(_))).cloned().unwrap_or(Skill::Done);
        Ok(exploration_harness::phase1::PolicyReply { proposed: Vec::new(), skill, done: false })
    }

    fn usage(&self) -> exploration_harness::PolicyUsage {
        exploration_harness::PolicyUsage::default()
    }
}

/// A narrowing frontier offers one place fewer each time the model passes over the
/// controller's first place, down to that place alone, and all of them again once it is
/// taken; without narrowing the offer stays as wide as the frontier.
#[test]
fn a_narrowing_frontier_closes_in_on_the_place_a_model_keeps_passing_over() {
    use exploration_harness::Frontier;
    use exploration_harness::phase1::explore;
    let (ontology, domain, grammar) = alfworld_parts();
    // The box is in none of the first places the controller ranks.
    let game = fixtures().join("alfworld/valid_seen/pick_and_place_simple-Box-None-Dresser-224/trial_T20190907_164104_229696/game.tw-pddl");
    let places_offered = |narrowing: bool| {
        let mut env = AlfworldEnv::from_game_file(&game).unwrap();
        let goal = parse_goal(env.goal()).unwrap();
        let mut adapter = AlfworldAdapter::new(ontology.clone(), domain.clone(), grammar.clone(), env.goal());
        let first = env.reset();
        let frontier = Some(Frontier { width: 3, narrowing });
        let exploration = explore(&mut env, &mut adapter, &mut LastPlace, &goal, &first, 12, frontier).expect("the run goes on");
        let decisions = &exploration.record.decisions;
        assert!(decisions.len() >= 4, "{decisions:?}");
        let gotos = |d: &exploration_harness::phase1::Decision| d.offered.iter().filter(|s| s.starts_with("goto ")).count();
        // The first place offered each time, and whether the model took it.
        let took_first: Vec<bool> = decisions.iter().map(|d| d.offered.iter().find(|s| s.starts_with("goto ")) == Some(&d.skill)).collect();
        (decisions.iter().map(gotos).collect::<Vec<usize>>(), took_first)
    };
    let (wide, _) = places_offered(false);
    assert!(wide.iter().all(|&n| n == 3), "{wide:?}");
    let (narrowing, took_first) = places_offered(true);
    assert_eq!(narrowing[..4], [3, 2, 1, 3], "passed over twice, then taken");
    assert_eq!(took_first[..4], [false, false, true, false]);
}

/// The reply instruction's example fact is in the benchmark's own vocabulary, the one its
/// perceiver reads back (VirtualHome's prompts showed ALFWorld's `inReceptacle`).
#[test]
fn the_example_fact_is_in_the_benchmark_s_vocabulary() {
    use exploration_harness::Skill;
    use exploration_harness::chat_policy::user_prompt;
    use exploration_harness::phase1::{PolicyInput, Skills};
    let skills = Skills { list: vec![Skill::Done], sweep: None };
    let observation = household_sim::Observation::text("You are in the kitchen.");
    let prompt = |benchmark: &str| {
        user_prompt(&PolicyInput {
            benchmark,
            task: "put the plate in the cabinet",
            objects: &["plate".to_string()],
            belief: Vec::new(),
            history: Vec::new(),
            skills: &skills,
            feedback: "This is the first step.",
            observation: &observation,
        })
    };
    let virtualhome = prompt("virtualhome-rearrange");
    assert!(virtualhome.contains("e.g. INSIDE(plate (9001), cabinet (9002))") && !virtualhome.contains("inReceptacle"), "{virtualhome}");
    assert!(prompt("alfworld").contains("e.g. inReceptacle(mug 2, countertop 1)"));
    // The example reads back as a fact in VirtualHome's vocabulary.
    let fact = exploration_harness::Fact::parse(exploration_harness::chat_policy::VIRTUALHOME_EXAMPLE).expect("a fact");
    assert_eq!((fact.predicate.as_str(), fact.args.len()), ("INSIDE", 2));
    // Its ids are no node's of any scene in fixtures/ (EAI's and the rearrangement set's), so
    // the prompt names no instance the agent has not perceived.
    let mut scenes = 0;
    for folder in ["virtualhome-eai/graphs", "virtualhome-rearrange"] {
        for file in std::fs::read_dir(fixtures().join(folder)).expect("scenes") {
            let path = file.expect("entry").path();
            if !path.to_string_lossy().ends_with(".json.gz") {
                continue;
            }
            let mut text = String::new();
            std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(std::fs::File::open(&path).expect("opens")), &mut text)
                .expect("gzip");
            for id in ["9001", "9002"] {
                assert!(
                    !text.contains(&format!("\"id\": {id}")) && !text.contains(&format!("\"id\":{id}")),
                    "{}: node {id}",
                    path.display()
                );
            }
            scenes += 1;
        }
    }
    assert!(scenes > 200, "{scenes} scenes read");
}
