//! The Phase II planning prompt on the real benchmarks (every ALFWorld valid_seen game, every
//! EAI problem, the IPC sets): names the agent could perceive, action forms the spelling
//! writes, goal relevance, and the whole prompt of one small task per benchmark as an insta
//! snapshot (`tests/snapshots/`) so that format changes are deliberate.

use benchmark_data::{Benchmark, Extra, TaskFiles};
use grounding::{FactId, Task};
use mcts::prompt::{PlanningPrompt, PromptOptions, PromptStyle, Relevance, planning_prompt, relevant_facts};
use transition_model::{Spelling, SurfaceLanguage, TransitionModel};

struct Loaded {
    id: String,
    model: TransitionModel,
    spelling: Spelling,
}

fn load(files: &TaskFiles) -> Loaded {
    let domain = pddl_syntax::parse_domain(&files.domain).expect("domain parses");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("problem parses");
    let task = grounding::ground(&domain, &problem).expect("grounds");
    let spelling = match &files.extra {
        Extra::Alfworld(game) => Spelling::alfworld(&task, &game.grammar).expect("grammar"),
        Extra::Virtualhome { .. } => Spelling::virtualhome(&task),
        Extra::None => Spelling::pddl(&task),
    };
    Loaded { id: files.id.clone(), model: TransitionModel::new(task), spelling }
}

fn load_all(benchmark: Benchmark) -> Vec<Loaded> {
    benchmark_data::load(benchmark).expect("fixtures load").iter().map(load).collect()
}

fn load_one(benchmark: Benchmark, id: &str) -> Loaded {
    let files = benchmark_data::load(benchmark).expect("fixtures load");
    load(files.iter().find(|f| f.id == id).expect("task exists"))
}

fn prompt(task: &Loaded, relevance: Relevance) -> PlanningPrompt {
    let options = PromptOptions { relevance, ..PromptOptions::default() };
    planning_prompt(&task.model, &task.spelling, &task.model.initial_state(), &options)
}

/// The lines of the user message's section `header` (up to the next blank line).
fn section<'a>(user: &'a str, header: &str) -> Vec<&'a str> {
    let start = user.find(&format!("{header}\n")).unwrap_or_else(|| panic!("no `{header}` in\n{user}")) + header.len() + 1;
    user[start..].lines().take_while(|l| !l.is_empty()).collect()
}

/// Words as a prompt reader splits them: on white space and `:,()<>`.
fn words(text: &str) -> Vec<&str> {
    text.split(|c: char| c.is_whitespace() || ":,()<>".contains(c)).filter(|w| !w.is_empty()).collect()
}

fn contains_words(haystack: &[&str], needle: &str) -> bool {
    let needle = words(needle);
    haystack.windows(needle.len()).any(|w| w == needle.as_slice())
}

/// Checks what every prompt must have: both messages, the four sections, `Plan:` last.
fn check_shape(prompt: &PlanningPrompt, id: &str) {
    assert!(!prompt.system.is_empty(), "{id}: an empty system message is still a system turn");
    assert!(prompt.user.starts_with("Actions:\n"), "{id}");
    assert!(prompt.user.ends_with("\n\nPlan:"), "{id}: the plan starts right after the prompt");
    for header in ["Initial state:", "Goal:"] {
        assert!(!section(&prompt.user, header).is_empty(), "{id}: `{header}` has a line");
    }
}

/// The objects the goal names, agents aside.
fn goal_objects(task: &Task, omitted_type: &str) -> Vec<grounding::ObjectId> {
    let mut objects: Vec<grounding::ObjectId> = Vec::new();
    for disjunct in &task.goal.disjuncts {
        let facts = disjunct.literals().chain(disjunct.clauses.iter().flatten().copied()).map(|l| l.fact());
        for fact in facts {
            for &arg in &task.fact(fact).args {
                if !task.objects[arg.index()].types.iter().any(|t| t == omitted_type) && !objects.contains(&arg) {
                    objects.push(arg);
                }
            }
        }
    }
    objects
}

#[test]
fn alfworld_prompts_use_display_names_and_never_pddl_ids() {
    for task in load_all(Benchmark::AlfworldSeen) {
        let names = transition_model::alfworld::display_names(task.model.task());
        for relevance in [Relevance::default(), Relevance::All] {
            let prompt = prompt(&task, relevance);
            check_shape(&prompt, &task.id);
            let text = prompt.text();
            assert!(!text.contains("_bar_"), "{}: an ALFWorld object id leaked:\n{text}", task.id);
            // (The system message's example `apple 1` is no object of the task.)
            let user_words = words(&prompt.user);
            // ALFWorld problems also declare unused class constants (`AlarmClock - object`),
            // whose names are class words.
            let classes: Vec<&str> = names.iter().flatten().filter_map(|n| n.rsplit_once(' ')).map(|(class, _)| class).collect();
            for (object, name) in task.model.task().objects.iter().zip(&names) {
                if name.is_none() && !classes.contains(&object.name.as_str()) {
                    assert!(!user_words.contains(&object.name.as_str()), "{}: `{}` has no display name", task.id, object.name);
                }
            }
            // Every goal object: its class in the goal, its instances in the state, as `apple 1`.
            let state = section(&prompt.user, "Initial state:").join("\n");
            let goal = section(&prompt.user, "Goal:").join("\n");
            let (state_words, goal_words) = (words(&state), words(&goal));
            for object in goal_objects(task.model.task(), "agent") {
                let object_types = &task.model.task().objects[object.index()].types;
                if object_types.iter().any(|t| t == "location") {
                    continue;
                }
                let name = names[object.index()].as_deref().expect("goal objects have display names");
                let class = name.rsplit_once(' ').map_or(name, |(class, _)| class);
                assert!(contains_words(&goal_words, class), "{}: goal lacks `{class}`:\n{goal}", task.id);
                assert!(contains_words(&state_words, name), "{}: state lacks `{name}`:\n{state}", task.id);
            }
        }
    }
}

#[test]
fn virtualhome_prompts_name_goal_objects_by_class_and_show_no_instance_ids() {
    for task in load_all(Benchmark::VirtualhomeEai) {
        let prompt = prompt(&task, Relevance::default());
        check_shape(&prompt, &task.id);
        let text = prompt.text();
        let bytes = text.as_bytes();
        let instance_id = bytes.windows(2).position(|w| w[0] == b'_' && w[1].is_ascii_digit());
        assert_eq!(instance_id, None, "{}: `_<digit>` in\n{text}", task.id);
        assert!(!words(&text).contains(&"character"), "{}: the character is left out", task.id);
        let goal_words = words(&section(&prompt.user, "Goal:").join("\n")).into_iter().map(str::to_string).collect::<Vec<_>>();
        for object in goal_objects(task.model.task(), "character") {
            let name = &task.model.task().objects[object.index()].name;
            assert!(goal_words.contains(name), "{}: goal lacks `{name}`", task.id);
        }
    }
}

/// Whether `text` is `form` with each `<placeholder>` standing for one or more words.
fn matches_form(form: &[&str], text: &[&str]) -> bool {
    match form.split_first() {
        None => text.is_empty(),
        Some((first, rest)) if first.starts_with('<') => {
            (1..=text.len()).any(|taken| !text[..taken].iter().any(|w| *w == "(" || *w == ")") && matches_form(rest, &text[taken..]))
        }
        Some((first, rest)) => text.first() == Some(first) && matches_form(rest, &text[1..]),
    }
}

/// Words and brackets, placeholders kept whole.
fn form_tokens(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, c) in text.char_indices() {
        if c.is_whitespace() || c == '(' || c == ')' {
            if let Some(s) = start.take() {
                out.push(&text[s..i]);
            }
            if c != ' ' {
                out.push(&text[i..i + 1]);
            }
        } else if start.is_none() {
            start = Some(i);
        }
    }
    if let Some(s) = start {
        out.push(&text[s..]);
    }
    out
}

/// The `form` part of each `form: description` line of the action reference.
fn forms(prompt: &PlanningPrompt) -> Vec<String> {
    let lines = section(&prompt.user, "Actions:");
    assert_eq!(lines.last(), Some(&"DONE"), "the end marker closes the reference");
    lines[..lines.len() - 1]
        .iter()
        .map(|line| line.split_once(": ").unwrap_or_else(|| panic!("`{line}` is `form: description`")).0.to_string())
        .collect()
}

/// Every form is written by some action and every action's text has a form. The VirtualHome
/// spelling leaves the character out wherever it stands, so actions whose *object* is the
/// character (`walk_towards character character` is `walk`) have no form.
fn check_forms(task: &Loaded) {
    let prompt = prompt(task, Relevance::default());
    let forms = forms(&prompt);
    let model_task = task.model.task();
    let is_character = |o: &grounding::ObjectId| model_task.objects[o.index()].types.iter().any(|t| t == "character");
    let mut texts: Vec<&str> = Vec::new();
    for action in model_task.action_ids() {
        let Some(text) = task.spelling.spell(action) else { continue };
        let args = &model_task.action(action).args;
        if task.spelling.language() == SurfaceLanguage::Virtualhome && args.iter().skip(1).any(is_character) {
            continue;
        }
        texts.push(text);
    }
    let patterns: Vec<Vec<&str>> = forms.iter().map(|f| form_tokens(f)).collect();
    for text in &texts {
        let tokens = form_tokens(text);
        assert!(patterns.iter().any(|f| matches_form(f, &tokens)), "{}: `{text}` matches no form of {forms:?}", task.id);
    }
    for (form, tokens) in forms.iter().zip(&patterns) {
        let written = texts.iter().any(|t| matches_form(tokens, &form_tokens(t)));
        assert!(written, "{}: no action is written as `{form}`", task.id);
    }
    let mut distinct = forms.clone();
    distinct.sort();
    distinct.dedup();
    assert_eq!(distinct.len(), forms.len(), "{}: forms are listed once", task.id);
}

#[test]
fn the_action_reference_lists_exactly_the_forms_the_spelling_writes() {
    for benchmark in [Benchmark::AlfworldSeen, Benchmark::VirtualhomeEai, Benchmark::Ipc] {
        for task in load_all(benchmark) {
            check_forms(&task);
        }
    }
}

#[test]
fn alfworld_forms_come_from_the_game_templates() {
    let task = load_one(Benchmark::AlfworldSeen, "pick_heat_then_place_in_recep-Apple-None-DiningTable-26/trial_T20190907_060234_011675");
    let forms = forms(&prompt(&task, Relevance::default()));
    for expected in
        ["go to <receptacle>", "take <object> from <receptacle>", "move <object> to <receptacle>", "heat <object> with <receptacle>"]
    {
        assert!(forms.iter().any(|f| f == expected), "`{expected}` in {forms:?}");
    }
}

#[test]
fn relevance_keeps_every_goal_fact_and_grows_with_depth() {
    for benchmark in [Benchmark::AlfworldSeen, Benchmark::VirtualhomeEai, Benchmark::Ipc] {
        for task in load_all(benchmark) {
            let model_task = task.model.task();
            let goal_facts: Vec<FactId> = model_task
                .goal
                .disjuncts
                .iter()
                .flat_map(|d| d.literals().chain(d.clauses.iter().flatten().copied()).map(|l| l.fact()))
                .collect();
            let mut previous = relevant_facts(model_task, 0);
            for &fact in &goal_facts {
                assert_eq!(previous.step(fact), Some(0), "{}: goal fact {}", task.id, model_task.fact_name(fact));
            }
            for depth in 1..=4 {
                let relevant = relevant_facts(model_task, depth);
                assert!(
                    previous.iter().all(|f| relevant.step(f) == previous.step(f)),
                    "{}: depth {depth} keeps depth {}",
                    task.id,
                    depth - 1
                );
                assert!(relevant.iter().all(|f| relevant.step(f).is_some_and(|s| s <= depth)), "{}", task.id);
                previous = relevant;
            }
            let closure = relevant_facts(model_task, usize::MAX);
            assert!(previous.iter().all(|f| closure.contains(f)), "{}", task.id);
        }
    }
}

/// A four-fact chain, drawn:
///
/// ```text
/// make-a: -> a      make-b: a -> b      make-c: b -> c      spoil: -> ¬c, and when a: d
/// ```
///
/// Goal `c ∧ ¬d`. Step 0: c, d. `make-c` achieves c and needs b (step 1); `make-b` achieves
/// b and needs a (step 2). `spoil` deletes c and adds d, so it achieves neither `c` nor `¬d`
/// and brings nothing (its condition a comes in through `make-b` only).
#[test]
fn relevance_regresses_through_achievers_on_a_hand_drawn_chain() {
    let domain = pddl_syntax::parse_domain(
        "(define (domain chain) (:requirements :adl) (:predicates (a) (b) (c) (d))
          (:action make-a :parameters () :effect (a))
          (:action make-b :parameters () :precondition (a) :effect (b))
          (:action make-c :parameters () :precondition (b) :effect (c))
          (:action spoil :parameters () :effect (and (not (c)) (when (a) (d)))))",
    )
    .expect("domain parses");
    let problem =
        pddl_syntax::parse_problem("(define (problem p) (:domain chain) (:init) (:goal (and (c) (not (d)))))").expect("problem parses");
    let task = grounding::ground(&domain, &problem).expect("grounds");
    let step = |depth: usize, name: &str| {
        let fact = task.fact_ids().find(|&f| task.fact_name(f) == name).expect("fact exists");
        relevant_facts(&task, depth).step(fact)
    };
    assert_eq!([step(0, "(c)"), step(0, "(d)"), step(0, "(b)"), step(0, "(a)")], [Some(0), Some(0), None, None]);
    assert_eq!([step(1, "(b)"), step(1, "(a)")], [Some(1), None]);
    assert_eq!([step(2, "(b)"), step(2, "(a)")], [Some(1), Some(2)]);
    assert_eq!(relevant_facts(&task, usize::MAX).len(), 4);
}

#[test]
fn a_conditional_effect_brings_its_condition() {
    let domain = pddl_syntax::parse_domain(
        "(define (domain switch) (:requirements :adl) (:predicates (power) (lamp) (plugged))
          (:action plug :parameters () :effect (plugged))
          (:action press :parameters () :precondition (power) :effect (when (plugged) (lamp)))
          (:action supply :parameters () :effect (power)))",
    )
    .expect("domain parses");
    let problem = pddl_syntax::parse_problem("(define (problem p) (:domain switch) (:init) (:goal (lamp)))").expect("problem parses");
    let task = grounding::ground(&domain, &problem).expect("grounds");
    let relevant = relevant_facts(&task, 1);
    let names: Vec<String> = relevant.iter().map(|f| task.fact_name(f)).collect();
    assert_eq!(names.len(), 3, "{names:?}");
    for name in ["(lamp)", "(power)", "(plugged)"] {
        assert!(names.iter().any(|n| n == name), "{name} in {names:?}");
    }
}

#[test]
fn the_default_relevance_shows_less_than_all_and_all_shows_every_true_fact() {
    let task = load_one(Benchmark::Ipc, "blocks/instance-1");
    let all = prompt(&task, Relevance::All);
    let state = section(&all.user, "Initial state:");
    let initial = task.model.initial_state();
    assert!(state.len() >= initial.len(), "every true fluent fact is shown");
    for fact in initial.facts() {
        let name = task.model.task().fact_name(fact);
        let line = name.trim_start_matches('(').trim_end_matches(')');
        assert!(state.contains(&line), "`{line}` in {state:?}");
    }
    let alfworld =
        load_one(Benchmark::AlfworldSeen, "pick_heat_then_place_in_recep-Apple-None-DiningTable-26/trial_T20190907_060234_011675");
    let (short, long) = (prompt(&alfworld, Relevance::default()), prompt(&alfworld, Relevance::All));
    assert!(section(&short.user, "Initial state:").len() * 4 < section(&long.user, "Initial state:").len());
    // What the plan needs is still there: where the apple is, the microwave, the dining tables.
    let state = section(&short.user, "Initial state:");
    for line in ["inreceptacle apple 1 diningtable 2", "openable microwave 1", "receptacle diningtable 1"] {
        assert!(state.contains(&line), "`{line}` in {state:?}");
    }
    assert_eq!(section(&short.user, "Goal:"), ["inreceptacle apple diningtable", "ishot apple"]);
}

#[test]
fn an_existential_alfworld_goal_collapses_to_classes_and_lists_what_differs() {
    let task = load_one(Benchmark::AlfworldSeen, "look_at_obj_in_light-AlarmClock-None-DeskLamp-323/trial_T20190909_044715_250790");
    let prompt = prompt(&task, Relevance::default());
    assert_eq!(
        section(&prompt.user, "Goal:"),
        ["holds alarmclock", "istoggled desklamp", "one of:", "- atlocation sidetable", "- atlocation desk"]
    );
}

#[test]
fn prompt_style_follows_the_spelling() {
    assert_eq!(PromptStyle::from(SurfaceLanguage::Alfworld), PromptStyle::Alfworld);
    assert_eq!(PromptStyle::from(SurfaceLanguage::Virtualhome), PromptStyle::Virtualhome);
    assert_eq!(PromptStyle::from(SurfaceLanguage::Pddl), PromptStyle::Pddl);
    assert_eq!(PromptOptions::default().end_marker.as_deref(), Some("DONE"), "the constraint's end marker");
}

/// Both messages as one text, the boundary marked, for a snapshot.
fn snapshot_text(prompt: &PlanningPrompt) -> String {
    format!("[system]\n{}\n\n[user]\n{}", prompt.system, prompt.user)
}

/// The whole prompt of one small task per benchmark and prompt style, as insta snapshots
/// (`tests/snapshots/prompt__*.snap`): the prompts are a contract, so that any change of
/// format is deliberate and shows in review.
#[test]
fn the_virtualhome_prompt_of_eai_1004_2() {
    let task = load_one(Benchmark::VirtualhomeEai, "1004_2");
    let prompt = prompt(&task, Relevance::default());
    check_shape(&prompt, &task.id);
    insta::assert_snapshot!(snapshot_text(&prompt));
}

#[test]
fn the_alfworld_prompt_of_a_heat_then_place_game() {
    let task = load_one(Benchmark::AlfworldSeen, "pick_heat_then_place_in_recep-Apple-None-DiningTable-26/trial_T20190907_060234_011675");
    let prompt = prompt(&task, Relevance::default());
    check_shape(&prompt, &task.id);
    insta::assert_snapshot!(snapshot_text(&prompt));
}

/// An IPC puzzle with every true fact shown, as the prompt module advises for IPC.
#[test]
fn the_pddl_prompt_of_ipc_blocks_instance_1() {
    let task = load_one(Benchmark::Ipc, "blocks/instance-1");
    let prompt = prompt(&task, Relevance::All);
    check_shape(&prompt, &task.id);
    insta::assert_snapshot!(snapshot_text(&prompt));
}

/// The assistant's turn opens right after the prompt, thinking off (Qwen3's template writes
/// the empty think block: the paper's Phase II decodes with thinking off).
#[test]
#[cfg(feature = "decoder")]
fn render_opens_the_assistant_turn_right_after_the_prompt() {
    let path = benchmark_data::fixtures_dir().join("tokenizers/qwen3/tokenizer.json");
    let tokenizer = lm::Tokenizer::from_tokenizer_json(&path).expect("Qwen3 tokenizer loads");
    let model = lm::UniformModel::new(std::sync::Arc::new(tokenizer));
    let task = load_one(Benchmark::VirtualhomeEai, "1004_2");
    let prompt = prompt(&task, Relevance::default());
    let rendered = prompt.render(&model).expect("chat template renders");
    let expected = format!(
        "<|im_start|>system\n{}<|im_end|>\n<|im_start|>user\n{}<|im_end|>\n<|im_start|>assistant\n<think>\n\n</think>\n\n",
        prompt.system, prompt.user
    );
    assert_eq!(rendered, expected);
}
