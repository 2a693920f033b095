//! Phase II by a chat model (the unconstrained thinking / greedy conditions): the request it
//! sends, and how the reply's plan text is read, on a real ALFWorld episode whose Phase I is the
//! systematic sweep. The chat model is scripted: it answers with A*'s plan spelled as the game
//! spells commands, wrapped in the decorations real models add.

use std::path::{Path, PathBuf};

use exploration_harness::alfworld::AlfworldAdapter;
use exploration_harness::chat_planner::{ChatPlannerConfig, plan_by_chat, strip_thinking};
use exploration_harness::{Attribution, EpisodeConfig, Grounded, Ontology, RunError, Systematic, parse_goal, run_episode};
use household_sim::{AlfworldEnv, Environment};
use vlm_client::{ChatError, ChatErrorKind, ChatModel, ChatReply, ChatRequest, Usage};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// Answers with `answer(plan lines)`, where the plan is A*'s on the grounded problem.
/// With `fail`, every request fails so.
struct Scripted<'a> {
    answer: &'a dyn Fn(&[String]) -> String,
    plan: Vec<String>,
    requests: Vec<ChatRequest>,
    fail: Option<ChatErrorKind>,
}

impl ChatModel for Scripted<'_> {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        self.requests.push(request.clone());
        if let Some(kind) = &self.fail {
            return Err(ChatError { kind: kind.clone(), url: "scripted".into(), attempts: 3, elapsed: Default::default() });
        }
        let usage = Usage { requests: 1, prompt_tokens: 300, completion_tokens: 42, reasoning_tokens: None, images: 0 };
        Ok(ChatReply::local((self.answer)(&self.plan), usage))
    }

    fn endpoint(&self) -> String {
        "scripted".into()
    }

    fn usage(&self) -> Usage {
        Usage::default()
    }
}

/// One episode on a pick-and-place game with the chat planner answering `answer`.
fn episode(answer: &dyn Fn(&[String]) -> String, config: &ChatPlannerConfig) -> (exploration_harness::Episode, Vec<ChatRequest>) {
    let (ep, requests) = attempt(answer, config, None);
    (ep.expect("the run goes on"), requests)
}

/// The episode, or the run's error, with the chat planner failing as `fail` says.
fn attempt(
    answer: &dyn Fn(&[String]) -> String,
    config: &ChatPlannerConfig,
    fail: Option<ChatErrorKind>,
) -> (Result<exploration_harness::Episode, RunError>, Vec<ChatRequest>) {
    let game = fixtures().join("alfworld/valid_seen/pick_and_place_simple-Book-None-Sofa-229/trial_T20190907_042856_259139/game.tw-pddl");
    let ontology =
        Ontology::from_text(&std::fs::read_to_string(fixtures().join("ontology/alfworld.txt")).unwrap(), "alfworld.txt").unwrap();
    let domain = pddl_syntax::parse_domain(&std::fs::read_to_string(fixtures().join("alfworld/alfred.pddl")).unwrap()).unwrap();
    let grammar = std::fs::read_to_string(fixtures().join("alfworld/alfred.twl2")).unwrap();
    let mut env = AlfworldEnv::from_game_file(&game).unwrap();
    let goal = parse_goal(env.goal()).unwrap();
    let mut adapter = AlfworldAdapter::new(ontology, domain, grammar, env.goal());
    let mut requests = Vec::new();
    let mut planner = |g: &Grounded| {
        let actions = heuristics::search::optimal_plan_expanding(&g.model, 1_000_000).expect("A* plans the hand-over");
        let plan = actions.iter().map(|&a| g.spelling.spell(a).expect("spelled").to_string()).collect();
        let mut chat = Scripted { answer, plan, requests: Vec::new(), fail: fail.clone() };
        let result = plan_by_chat(&mut chat, g, config);
        requests = chat.requests;
        result
    };
    let ep = run_episode(&mut env, &mut adapter, &mut Systematic, &goal, EpisodeConfig::open_loop(55), &mut planner);
    (ep, requests)
}

#[test]
fn a_thinking_reply_with_a_numbered_plan_wins_the_episode() {
    let answer = |plan: &[String]| {
        let numbered: Vec<String> = plan.iter().enumerate().map(|(i, line)| format!("{}. {line}", i + 1)).collect();
        format!("<think>\nThe book is on the bed; go to desk 1? No.\n</think>\n\n{}\nDONE\n", numbered.join("\n"))
    };
    let (ep, requests) = episode(&answer, &ChatPlannerConfig::thinking());
    assert!(ep.success, "{:?}", ep.failure);
    assert_eq!((ep.phase2_calls, ep.phase2_tokens), (1, 42));
    assert_eq!(ep.phase2_detail["valid"], true);
    assert!(!ep.phase2_detail["plan_text"].as_str().unwrap().contains("think"), "the thinking is not the plan");
    // The request: the planning prompt as system + user, thinking on, temperature zero (the
    // main paper's thinking rows), 32K tokens.
    let request = &requests[0];
    assert_eq!(request.messages.len(), 2);
    assert!(request.messages[1].joined_text().contains("Plan:"));
    assert_eq!(request.chat_template_kwargs.as_ref().unwrap()["enable_thinking"], true);
    assert_eq!((request.sampling.temperature, request.sampling.top_k, request.sampling.max_tokens), (Some(0.0), None, Some(32_768)));
    assert_eq!(ep.phase2_detail["temperature"], 0.0);
}

#[test]
fn recommended_thinking_samples_as_the_papers_appendix_with_the_runs_seed() {
    let answer = |plan: &[String]| format!("<think>ok</think>\n{}\n", plan.join("\n"));
    let (ep, requests) = episode(&answer, &ChatPlannerConfig::thinking_recommended(1738));
    assert!(ep.success, "{:?}", ep.failure);
    let request = &requests[0];
    assert_eq!(request.chat_template_kwargs.as_ref().unwrap()["enable_thinking"], true);
    let s = &request.sampling;
    assert_eq!((s.temperature, s.top_p, s.top_k, s.max_tokens, s.seed), (Some(1.0), Some(0.95), Some(20), Some(32_768), Some(1738)));
    assert_eq!((ep.phase2_detail["top_k"].as_u64(), ep.phase2_detail["seed"].as_u64()), (Some(20), Some(1738)));
}

#[test]
fn a_line_naming_no_applicable_action_ends_the_plan_at_its_valid_prefix() {
    let answer = |plan: &[String]| format!("{}\nteleport to the book\n{}\n", plan[0], plan[1..].join("\n"));
    let (ep, requests) = episode(&answer, &ChatPlannerConfig::greedy());
    assert!(!ep.success);
    assert_eq!(ep.plan.len(), 1, "the valid prefix: {:?}", ep.plan);
    assert_eq!(ep.phase2_detail["invalid"], "line 2: \"teleport to the book\"");
    let request = &requests[0];
    assert_eq!(request.chat_template_kwargs.as_ref().unwrap()["enable_thinking"], false);
    assert_eq!((request.sampling.temperature, request.sampling.max_tokens), (Some(0.0), Some(512)));
}

/// A planner that cannot reach its model stops the run: no episode to record (a rerun resumes
/// the task), and so does a server that rejects the request's form or answers with something
/// that is no chat completion; a request the server refuses as past the model's context is the
/// planner's failure, recorded as no plan.
#[test]
fn an_unreachable_planner_stops_the_run_and_a_refused_request_is_no_plan() {
    let answer = |plan: &[String]| plan.join("\n");
    let status = |status: u16, body: &str| ChatErrorKind::Status { status, body: body.into(), retry_after: None };
    for kind in [
        ChatErrorKind::Connect("refused".into()),
        status(503, ""),
        status(400, "Unrecognized request argument supplied: chat_template_kwargs"),
        ChatErrorKind::MalformedReply("not JSON: <html>Bad Gateway</html>".into()),
    ] {
        let (ep, requests) = attempt(&answer, &ChatPlannerConfig::greedy(), Some(kind.clone()));
        let error = ep.expect_err("the run stops");
        assert!(error.0.contains("unavailable"), "{kind:?}: {error}");
        assert_eq!(requests.len(), 1);
    }
    let too_long = status(400, "This model's maximum context length is 4096 tokens. However, you requested 5000 tokens (too long)");
    let (ep, _) = attempt(&answer, &ChatPlannerConfig::greedy(), Some(too_long));
    let ep = ep.expect("an episode");
    assert!(!ep.success && ep.no_plan, "{:?}", ep.failure);
    assert!(
        ep.failure.as_deref().is_some_and(|f| f.starts_with("no plan: context-overflow: ") && f.contains("too long")),
        "{:?}",
        ep.failure
    );
    assert_eq!(ep.phase2_detail["stop"], "context-overflow");
    assert_eq!(ep.phase2_calls, 1);
    assert_eq!(ep.attribution, Some(Attribution::Search));
}

#[test]
fn thinking_is_cut_at_the_last_closing_tag() {
    assert_eq!(strip_thinking("<think>a</think>b</think>\nplan"), "\nplan");
    assert_eq!(strip_thinking("plan only"), "plan only");
}

#[test]
fn the_prompt_options_reach_the_chat_planner() {
    let answer = |plan: &[String]| plan.join("\n");
    let (relevant, requests) = episode(&answer, &ChatPlannerConfig::greedy());
    assert!(relevant.success, "{:?}", relevant.failure);
    let mut all = ChatPlannerConfig::greedy();
    all.prompt.relevance = mcts::prompt::Relevance::All;
    let (every, all_requests) = episode(&answer, &all);
    assert!(every.success, "{:?}", every.failure);
    let (few, many) = (requests[0].messages[1].joined_text(), all_requests[0].messages[1].joined_text());
    // The state, named as the agent perceived it (never an empty state, never a type name for
    // an object): the book where it was found, and the goal's classes.
    assert!(few.contains("inreceptacle book 1 "), "{few}");
    assert!(few.contains("Goal:\ninreceptacle book sofa"), "{few}");
    // Every fact the goal needs is shown either way, and all facts are more.
    assert!(many.len() > few.len(), "all facts: {} bytes; relevant facts: {} bytes", many.len(), few.len());
    for line in few.lines().filter(|l| l.starts_with("- ")) {
        assert!(many.contains(line), "{line} is missing from the all-facts prompt");
    }
}
