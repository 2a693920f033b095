//! f_φ through the chat interface, with a scripted chat model standing in for a served one:
//! the request carries the paper's Phase I sections and the reply schema (the valid skills as an
//! enum); the policy's choice is followed; the facts it proposes never enter F_t unless an
//! observation states them.

use std::path::{Path, PathBuf};
use std::time::Duration;

use exploration_harness::alfworld::AlfworldAdapter;
use exploration_harness::chat_policy::ChatPolicy;
use exploration_harness::{EpisodeConfig, Grounded, Ontology, PhaseTwo, Policy, parse_goal, run_episode};
use household_sim::{AlfworldEnv, Environment};
use vlm_client::{ChatError, ChatModel, ChatReply, ChatRequest, Usage};

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
        let usage = Usage { requests: 1, prompt_tokens: 100, completion_tokens: 20, reasoning_tokens: None, images: 0 };
        self.usage.add(&usage);
        Ok(ChatReply {
            text,
            reasoning: None,
            finish_reason: Some("stop".into()),
            usage,
            json_mode: None,
            attempts: 1,
            waited: Duration::ZERO,
        })
    }

    fn endpoint(&self) -> String {
        "scripted".into()
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

#[test]
fn a_chat_policy_explores_and_its_proposals_stay_hypotheses() {
    let ontology =
        Ontology::from_text(&std::fs::read_to_string(fixtures().join("ontology/alfworld.txt")).unwrap(), "alfworld.txt").unwrap();
    let domain = pddl_syntax::parse_domain(&std::fs::read_to_string(fixtures().join("alfworld/alfred.pddl")).unwrap()).unwrap();
    let grammar = std::fs::read_to_string(fixtures().join("alfworld/alfred.twl2")).unwrap();
    let root = fixtures().join("alfworld/valid_seen");
    let mut families: Vec<PathBuf> = std::fs::read_dir(&root).unwrap().map(|f| f.unwrap().path()).collect();
    families.sort();
    let mut won = 0;
    for family in families.iter().step_by(7) {
        let game = std::fs::read_dir(family).unwrap().next().unwrap().unwrap().path().join("game.tw-pddl");
        let mut env = AlfworldEnv::from_game_file(&game).unwrap();
        let goal = parse_goal(env.goal()).unwrap();
        let mut adapter = AlfworldAdapter::new(ontology.clone(), domain.clone(), grammar.clone(), env.goal());
        let mut policy = ChatPolicy::new(Box::new(Scripted { usage: Usage::default(), prompts: Vec::new() }), "scripted");
        let mut planner = |g: &Grounded| {
            heuristics::search::optimal_plan(&g.model, Duration::from_secs(20))
                .map(|actions| PhaseTwo { actions, ..PhaseTwo::default() })
                .map_err(|s| format!("{s:?}"))
        };
        let episode =
            run_episode(&mut env, &mut adapter, &mut policy, &goal, EpisodeConfig { budget: 55, closed_loop: false }, &mut planner);
        won += usize::from(episode.success);
        let usage = policy.usage();
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
