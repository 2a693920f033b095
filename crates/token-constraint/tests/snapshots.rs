//! Snapshots of what constrained decoding allows on a real ALFWorld game, where the text is
//! the contract: the language (the distinct texts of the applicable actions, and whether the
//! plan may end) of states along the expert walkthrough under both end policies, and the
//! Qwen3 tokens allowed after a few partial actions, written as their text.

use std::fmt::Write;

use benchmark_data::{Benchmark, Extra, fixtures_dir, load};
use token_constraint::hf::vocabulary_from_file;
use token_constraint::{EndPolicy, LanguageConfig, Matcher, PlanLanguages, Step, Vocabulary};
use transition_model::{Spelling, State, TransitionModel};

const GAME: &str = "pick_and_place_simple-ToiletPaper-None-ToiletPaperHanger-406/";

struct Game {
    id: String,
    model: TransitionModel,
    spelling: Spelling,
    walkthrough: Vec<String>,
}

fn game() -> Game {
    let files = load(Benchmark::AlfworldSeen).expect("fixtures load").into_iter().find(|t| t.id.starts_with(GAME)).expect("the game");
    let Extra::Alfworld(game) = &files.extra else { unreachable!("ALFWorld tasks carry their game") };
    let domain = pddl_syntax::parse_domain(&files.domain).expect("domain parses");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("problem parses");
    let model = TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"));
    let spelling = Spelling::alfworld(model.task(), &game.grammar).expect("grammar");
    Game { id: files.id, model, spelling, walkthrough: game.walkthrough.clone() }
}

/// The language of `state`: one text a line, sorted, marked where the plan may end right
/// after it, with the number of applicable actions it names when more than one.
fn language(out: &mut String, languages: &mut PlanLanguages<'_>, state: &State) {
    let language = languages.language(state).expect("the language builds");
    let mut texts: Vec<(String, bool, usize)> = (0..language.language.choices() as u32)
        .map(|c| {
            let text = String::from_utf8(language.language.text(c).to_vec()).expect("UTF-8");
            (text, language.language.end_after(c), language.actions(c).len())
        })
        .collect();
    texts.sort();
    writeln!(out, "  {} texts; the plan may end here (DONE or EOS): {}", texts.len(), language.language.end_here()).unwrap();
    for (text, end_after, actions) in texts {
        let end = if end_after { "  [then EOS ends the plan]" } else { "" };
        let many = if actions > 1 { format!("  ({actions} actions)") } else { String::new() };
        writeln!(out, "    {text}{end}{many}").unwrap();
    }
}

#[test]
fn languages_along_the_walkthrough() {
    let game = game();
    let states = game.model.states_along(&game.spelling, &game.walkthrough).expect("the walkthrough applies");
    let mut out = format!("{}\nwalkthrough: {}\n", game.id, game.walkthrough.join(" | "));
    for policy in [EndPolicy::Anywhere, EndPolicy::AtGoal] {
        let mut languages = PlanLanguages::with_config(&game.model, &game.spelling, LanguageConfig::default(), policy);
        // The initial state, the open cabinet holding the toilet paper, and the state before
        // the last step (where the last step reaches the goal).
        for step in [0, 2, game.walkthrough.len() - 1] {
            writeln!(out, "\n{policy:?}, after {step} steps:").unwrap();
            language(&mut out, &mut languages, &states[step]);
        }
    }
    insta::assert_snapshot!(out);
}

#[test]
fn qwen3_tokens_allowed_after_partial_actions() {
    let (vocab, tokenizer): (Vocabulary, _) =
        vocabulary_from_file(&fixtures_dir().join("tokenizers/qwen3/tokenizer.json")).expect("Qwen3 reads");
    let game = game();
    let states = game.model.states_along(&game.spelling, &game.walkthrough).expect("the walkthrough applies");
    let mut languages = PlanLanguages::new(&game.model, &game.spelling);
    let language = languages.language(&states[2]).expect("the language builds");
    let mut out = format!("{}, after 2 steps (`{}`)\n", game.id, game.walkthrough[..2].join(" | "));
    for prefix in ["", "take", "take toiletpaper 1 from", "go to toilet", "go to toiletpaperhanger 1", "close cabinet 1"] {
        let mut matcher = Matcher::new(language.language.clone());
        let tokens = tokenizer.encode(prefix, false).expect("encodes").get_ids().to_vec();
        for &token in &tokens {
            assert_eq!(matcher.advance(&vocab, token), Ok(Step::Partial), "`{prefix}`: the canonical tokens are allowed");
        }
        let mut allowed = Vec::new();
        matcher.allowed(&vocab, &mut allowed);
        // Each token as its text; end-of-sequence tokens marked.
        let mut texts: Vec<String> = allowed
            .iter()
            .map(|&t| {
                let text = format!("{:?}", String::from_utf8_lossy(vocab.token_bytes(t)));
                if vocab.is_eos(t) { format!("EOS {text}") } else { text }
            })
            .collect();
        texts.sort();
        writeln!(out, "\nafter {prefix:?} ({} tokens): {} allowed", tokens.len(), texts.len()).unwrap();
        for line in texts.chunks(8) {
            writeln!(out, "  {}", line.join(" ")).unwrap();
        }
    }
    insta::assert_snapshot!(out);
}
