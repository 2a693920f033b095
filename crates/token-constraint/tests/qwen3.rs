//! The laws on the real vocabulary (Qwen3, 151,669 tokens) and real states (ALFWorld games
//! and EAI VirtualHome problems, along their expert plans and along random walks):
//! canonical tokenizations of every applicable action are accepted token by token, whole
//! expert plans decode to the plan the transition model validates, masks equal a
//! brute-force scan of the vocabulary, and decoding random allowed tokens only ever writes
//! applicable actions.

use std::path::PathBuf;
use std::sync::OnceLock;

use benchmark_data::{Benchmark, Extra, TaskFiles, fixtures_dir, load};
use token_constraint::hf::vocabulary_from_file;
use token_constraint::{EndPolicy, Language, LanguageConfig, Matcher, PlanConstraint, PlanLanguages, PlanStep, Step, Vocabulary};
use tokenizers::Tokenizer;
use transition_model::{PlanError, Spelling, State, TransitionModel};

fn qwen() -> &'static (Vocabulary, Tokenizer) {
    static QWEN: OnceLock<(Vocabulary, Tokenizer)> = OnceLock::new();
    QWEN.get_or_init(|| {
        let path: PathBuf = fixtures_dir().join("tokenizers/qwen3/tokenizer.json");
        vocabulary_from_file(&path).expect("the Qwen3 tokenizer reads")
    })
}

fn encode(text: &str) -> Vec<u32> {
    qwen().1.encode(text, false).expect("encodes").get_ids().to_vec()
}

struct Case {
    id: String,
    model: TransitionModel,
    spelling: Spelling,
    plan: Vec<String>,
}

fn case(files: &TaskFiles) -> Option<Case> {
    let domain = pddl_syntax::parse_domain(&files.domain).expect("domain parses");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("problem parses");
    let model = TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"));
    let (spelling, plan) = match &files.extra {
        Extra::Alfworld(game) => (Spelling::alfworld(model.task(), &game.grammar).expect("grammar"), game.walkthrough.clone()),
        Extra::Virtualhome { gold_plan: Some(plan), .. } => {
            let verbs = Spelling::virtualhome(model.task());
            let valid = model.validate_text(&Spelling::pddl(model.task()), plan).expect("gold plan validates");
            let plan = valid.actions.iter().map(|&a| verbs.spell(a).expect("verb").to_string()).collect();
            (verbs, plan)
        }
        _ => return None,
    };
    Some(Case { id: files.id.clone(), model, spelling, plan })
}

/// Every 10th ALFWorld valid_seen game and every 20th EAI problem with a gold plan.
fn cases() -> Vec<Case> {
    let alfworld = load(Benchmark::AlfworldSeen).expect("fixtures").into_iter().step_by(10);
    let virtualhome = load(Benchmark::VirtualhomeEai).expect("fixtures").into_iter().step_by(20);
    alfworld.chain(virtualhome).filter_map(|f| case(&f)).collect()
}

/// The states along the expert plan and along a random walk from the initial state.
fn states(case: &Case, seed: u64) -> Vec<State> {
    let mut states = case.model.states_along(&case.spelling, &case.plan).expect("expert plan validates");
    states.extend(case.model.random_walk(seed, 10));
    states
}

/// The oracle: the allowed language as plain strings, checked with `starts_with`.
fn brute_force(language: &Language, vocab: &Vocabulary, u: &[u8]) -> Vec<u32> {
    let mut strings: Vec<Vec<u8>> = (0..language.choices() as u32).map(|c| [language.text(c), b"\n"].concat()).collect();
    if language.end_here() {
        strings.push(b"DONE".to_vec());
    }
    (0..vocab.len() as u32)
        .filter(|&t| {
            if vocab.is_eos(t) {
                let text_end = (0..language.choices() as u32).any(|c| language.end_after(c) && language.text(c) == u);
                return (u.is_empty() && language.end_here()) || text_end;
            }
            let bytes = vocab.token_bytes(t);
            if vocab.is_special(t) || bytes.is_empty() {
                return false;
            }
            let extended = [u, bytes].concat();
            strings.iter().any(|s| s.starts_with(&extended))
        })
        .collect()
}

#[test]
fn the_qwen3_vocabulary_is_read_byte_exact_and_its_trie_is_small() {
    let (vocab, tokenizer) = qwen();
    assert_eq!(vocab.len(), 151_669);
    let eos: Vec<&str> = vocab.eos().iter().map(|&t| std::str::from_utf8(vocab.token_bytes(t)).unwrap()).collect();
    assert_eq!(eos, vec!["<|endoftext|>", "<|im_end|>"]);
    for text in ["go to cabinet 1\n", "walk_to kitchen\n", "Ĉafé — 東京\n\n", "  put mug 2 in/on coffeemachine 1"] {
        let ids = encode(text);
        assert_eq!(vocab.decode(&ids), text.as_bytes(), "{text:?} decodes back to its bytes");
        assert!(ids.iter().all(|&t| !vocab.is_special(t)));
    }
    assert_eq!(vocab.token_bytes(tokenizer.token_to_id("Ġthe").unwrap()), b" the");
    assert_eq!(vocab.token_bytes(tokenizer.token_to_id("Ċ").unwrap()), b"\n");
    assert!(vocab.is_special(tokenizer.token_to_id("<|im_start|>").unwrap()));
    let megabytes = vocab.heap_bytes() as f64 / 1e6;
    println!("Qwen3: {} trie nodes, {megabytes:.2} MB with the token bytes", vocab.trie().node_count());
    assert!(megabytes < 8.0, "the vocabulary and its trie take {megabytes:.2} MB");
}

#[test]
fn canonical_tokenizations_of_every_applicable_action_are_accepted_and_masks_match_brute_force() {
    let (vocab, _) = qwen();
    let mut actions = 0;
    let mut brute_forced = 0;
    for (index, case) in cases().iter().enumerate() {
        let mut languages = PlanLanguages::new(&case.model, &case.spelling);
        for (s, state) in states(case, index as u64).iter().enumerate() {
            let language = languages.language(state).expect("language builds");
            let root = Matcher::new(language.language.clone());
            for choice in 0..language.language.choices() as u32 {
                let text = std::str::from_utf8(language.language.text(choice)).unwrap().to_string();
                let tokens = encode(&format!("{text}\n"));
                let mut matcher = root.clone();
                for (i, &token) in tokens.iter().enumerate() {
                    let mask = matcher.mask(vocab);
                    assert!(mask.contains(token), "{}: `{text}`: canonical token {i} ({token}) is masked out", case.id);
                    let complete = (0..language.language.choices() as u32).any(|c| language.language.text(c) == matcher.prefix());
                    assert_eq!(mask.contains(vocab.eos()[0]), i == 0 || complete, "EOS only at a boundary");
                    // Brute force on the first state of each case, at every position of its first actions.
                    if s == 0 && choice < 3 {
                        assert_eq!(
                            mask.iter().collect::<Vec<_>>(),
                            brute_force(&language.language, vocab, matcher.prefix()),
                            "{}: `{text}` at {i}",
                            case.id
                        );
                        brute_forced += 1;
                    }
                    let step = matcher.advance(vocab, token).unwrap();
                    if i + 1 < tokens.len() {
                        assert_eq!(step, Step::Partial);
                    } else {
                        assert_eq!(step, Step::Action(choice), "{}: `{text}` completes", case.id);
                    }
                }
                for &action in language.actions(choice) {
                    assert!(case.model.is_applicable(state, action));
                    assert_eq!(case.spelling.spell(action), Some(text.as_str()));
                }
                actions += 1;
            }
            // Every spelled applicable action has its text in the language.
            let mut applicable = Vec::new();
            case.model.applicable(state, &mut applicable);
            for action in applicable {
                if let Some(text) = case.spelling.spell(action) {
                    assert!(
                        (0..language.language.choices() as u32)
                            .any(|c| language.language.text(c) == text.as_bytes() && language.actions(c).contains(&action))
                    );
                }
            }
        }
    }
    println!("{actions} canonical action tokenizations accepted; {brute_forced} masks equal to the brute-force scan");
    assert!(actions > 1000 && brute_forced > 100);
}

#[test]
fn expert_plans_decode_token_by_token_to_the_plan_the_model_validates() {
    let (vocab, _) = qwen();
    let mut plans = 0;
    for case in cases() {
        let expected = case.model.validate_text(&case.spelling, &case.plan).expect("validates");
        for policy in [EndPolicy::Anywhere, EndPolicy::AtGoal] {
            let mut languages = PlanLanguages::with_config(&case.model, &case.spelling, LanguageConfig::default(), policy);
            let mut constraint = PlanConstraint::new(&mut languages, case.model.initial_state()).unwrap();
            let text = format!("{}\nDONE", case.plan.join("\n"));
            let mut last = PlanStep::Partial;
            for token in encode(&text) {
                assert!(!constraint.is_finished());
                last = constraint.advance(&mut languages, vocab, token).unwrap_or_else(|e| panic!("{}: {e}", case.id));
            }
            assert_eq!(last, PlanStep::End { action: None, goal_reached: true }, "{}", case.id);
            assert_eq!(constraint.plan(), expected.actions.as_slice(), "{}", case.id);
            // Revisits are free: one language per distinct state.
            let (hits, misses) = languages.cache_stats();
            let mut distinct = case.model.states_along(&case.spelling, &case.plan).unwrap();
            distinct.sort_unstable();
            distinct.dedup();
            assert_eq!(misses as usize, distinct.len(), "{}: {hits} hits", case.id);
            // EOS straight after the last action (no separator) also ends the plan.
            let mut constraint = PlanConstraint::new(&mut languages, case.model.initial_state()).unwrap();
            for token in encode(&case.plan.join("\n")) {
                constraint.advance(&mut languages, vocab, token).unwrap();
            }
            let end = constraint.advance(&mut languages, vocab, vocab.eos()[0]).unwrap();
            assert_eq!(end, PlanStep::End { action: expected.actions.last().copied(), goal_reached: true }, "{}", case.id);
        }
        plans += 1;
    }
    assert!(plans >= 25, "{plans}");
}

#[test]
fn decoding_random_allowed_tokens_writes_only_applicable_actions() {
    let (vocab, _) = qwen();
    let mut completed = 0;
    let mut ended_at_goal = 0;
    for (index, case) in cases().iter().enumerate() {
        for policy in [EndPolicy::Anywhere, EndPolicy::AtGoal] {
            let mut languages = PlanLanguages::with_config(&case.model, &case.spelling, LanguageConfig::default(), policy);
            let mut constraint = PlanConstraint::new(&mut languages, case.model.initial_state()).unwrap();
            let mut rng = 0x9E37_79B9_7F4A_7C15u64 ^ index as u64;
            let mut allowed = Vec::new();
            for _ in 0..400 {
                constraint.allowed(vocab, &mut allowed);
                assert!(!allowed.is_empty(), "{}: a reachable u allows some token", case.id);
                allowed.sort_unstable();
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                let token = allowed[(rng % allowed.len() as u64) as usize];
                match constraint.advance(&mut languages, vocab, token).unwrap() {
                    PlanStep::Partial => {}
                    PlanStep::Action { .. } => completed += 1,
                    PlanStep::End { goal_reached, .. } => {
                        if policy == EndPolicy::AtGoal {
                            let mut applicable = Vec::new();
                            case.model.applicable(constraint.state(), &mut applicable);
                            assert!(goal_reached || applicable.is_empty(), "{}: ends only at the goal or a dead end", case.id);
                            ended_at_goal += usize::from(goal_reached);
                        }
                        break;
                    }
                }
            }
            // Replaying the written plan through the transition model: every step applies.
            match case.model.validate(constraint.plan()) {
                Ok(_) | Err(PlanError::GoalNotReached { .. }) => {}
                Err(e) => panic!("{}: {}", case.id, e.describe(case.model.task())),
            }
        }
    }
    println!("{completed} actions written by random constrained decoding; {ended_at_goal} plans ended at the goal");
    assert!(completed > 100);
}
