//! Real plans on real data: every ALFWorld expert walkthrough, spelled as TextWorld
//! commands, parses step by step into applicable actions and wins; every EAI gold PDDL
//! plan validates; broken plans are rejected at the step where they first fail.

use benchmark_data::{Benchmark, Extra, TaskFiles, load};
use transition_model::{PlanError, Spelling, TransitionModel};

fn model(files: &TaskFiles) -> TransitionModel {
    let domain = pddl_syntax::parse_domain(&files.domain).expect("domain parses");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("problem parses");
    TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"))
}

/// The step a broken plan is reported at must be the first one that fails: every step
/// before it applies, and it does not (or, for the goal, every step applies).
fn assert_first_failure(model: &TransitionModel, spelling: &Spelling, plan: &[String], error: &PlanError, id: &str) {
    let failing = match error {
        PlanError::UnknownAction { step, .. } | PlanError::Inapplicable { step, .. } => *step,
        PlanError::GoalNotReached { steps, .. } => {
            assert_eq!(*steps, plan.len(), "{id}");
            return;
        }
    };
    let mut state = model.initial_state();
    for (index, text) in plan.iter().enumerate() {
        let applicable = spelling.parse(text).iter().copied().find(|&a| model.is_applicable(&state, a));
        if index + 1 == failing {
            assert!(applicable.is_none(), "{id}: step {failing} was reported failing but applies");
            return;
        }
        let action = applicable.unwrap_or_else(|| panic!("{id}: step {} fails before the reported step {failing}", index + 1));
        state = model.apply(&state, action);
    }
    panic!("{id}: reported step {failing} is past the end of the plan");
}

#[test]
fn alfworld_walkthroughs_win_and_broken_ones_fail_at_the_right_step() {
    let mut won = 0;
    let mut steps = 0;
    let mut broken_rejected = 0;
    for benchmark in [Benchmark::AlfworldSeen, Benchmark::AlfworldTrain] {
        for files in load(benchmark).expect("fixtures load") {
            let Extra::Alfworld(game) = &files.extra else { unreachable!("ALFWorld tasks carry their game") };
            let model = model(&files);
            let spelling = Spelling::alfworld(model.task(), &game.grammar).expect("grammar templates compile");
            let plan = &game.walkthrough;
            if won == 0 {
                // Names for fewer objects than the task has leave the rest unnamed: their
                // actions have no spelling (no panic).
                let unnamed = Spelling::alfworld_with_names(model.task(), &game.grammar, Vec::new()).expect("grammar");
                assert!(plan.iter().all(|command| unnamed.parse(command).is_empty()), "{}", files.id);
            }
            for (index, command) in plan.iter().enumerate() {
                assert!(!spelling.parse(command).is_empty(), "{}: step {} `{command}` names no action", files.id, index + 1);
            }
            let valid = model.validate_text(&spelling, plan).unwrap_or_else(|e| panic!("{}: {}", files.id, e.describe(model.task())));
            assert_eq!(valid.actions.len(), plan.len());
            won += 1;
            steps += plan.len();

            // Without its last step no walkthrough wins (the last step completes the goal).
            let truncated = &plan[..plan.len() - 1];
            let error = model.validate_text(&spelling, truncated).expect_err("a walkthrough without its last step fails");
            assert!(matches!(error, PlanError::GoalNotReached { .. }), "{}: {error}", files.id);
            assert!(error.describe(model.task()).starts_with("invalid: goal"));
            // Without its first step (the agent never went anywhere) or with two steps
            // swapped, a walkthrough fails, and at the first step that does not apply.
            let mut variants = vec![plan[1..].to_vec()];
            for i in 0..plan.len() - 1 {
                let mut swapped = plan.clone();
                swapped.swap(i, i + 1);
                variants.push(swapped);
            }
            for variant in variants {
                if let Err(error) = model.validate_text(&spelling, &variant) {
                    assert_first_failure(&model, &spelling, &variant, &error, &files.id);
                    broken_rejected += 1;
                }
            }
            let error = model.validate_text(&spelling, &plan[1..]).expect_err("a walkthrough without its first step fails");
            assert!(matches!(error, PlanError::Inapplicable { .. } | PlanError::GoalNotReached { .. }), "{}", files.id);
        }
    }
    assert_eq!(won, 340);
    println!("ALFWorld: {won} walkthroughs win ({steps} steps); {broken_rejected} broken variants rejected at their first failing step");
}

#[test]
fn eai_gold_plans_validate_and_broken_ones_fail_at_the_right_step() {
    let mut valid = 0;
    let mut rejected = 0;
    for files in load(Benchmark::VirtualhomeEai).expect("fixtures load") {
        let Extra::Virtualhome { gold_plan: Some(plan), .. } = &files.extra else { continue };
        let model = model(&files);
        let spelling = Spelling::pddl(model.task());
        model.validate_text(&spelling, plan).unwrap_or_else(|e| panic!("{}: {}", files.id, e.describe(model.task())));
        valid += 1;
        for k in 0..plan.len() {
            let mut removed = plan.clone();
            removed.remove(k);
            if let Err(error) = model.validate_text(&spelling, &removed) {
                assert_first_failure(&model, &spelling, &removed, &error, &files.id);
                rejected += 1;
            }
        }
    }
    assert_eq!(valid, 296);
    println!("EAI: {valid} gold plans validate; {rejected} one-step-removed variants rejected at their first failing step");
}

#[test]
fn unknown_and_malformed_plan_steps_are_named() {
    let files = load(Benchmark::Ipc).expect("fixtures load").into_iter().find(|t| t.id == "blocks/instance-1").expect("blocks 1");
    let model = model(&files);
    let spelling = Spelling::pddl(model.task());
    let error = model.validate_text(&spelling, &["(pick-up a)", "(fly-away b)"]).unwrap_err();
    assert!(matches!(&error, PlanError::UnknownAction { step: 2, text } if text == "(fly-away b)"), "{error:?}");
    assert_eq!(error.describe(model.task()), "invalid: step 2: `(fly-away b)` is not an action of this task");
    let error = model.validate_text(&spelling, &["(stack a b)"]).unwrap_err();
    let line = error.describe(model.task());
    assert!(line.starts_with("invalid: step 1: `(stack a b)` is not applicable: unmet (holding a)"), "{line}");
    // The grounded action is named beside the text where the plan spelled it otherwise.
    let line = model.validate_text(&spelling, &["stack a b"]).unwrap_err().describe(model.task());
    assert!(line.starts_with("invalid: step 1: `stack a b` ((stack a b)) is not applicable"), "{line}");
    // Space inside the parentheses is no part of the action, as for VAL (it was "not an action").
    for text in ["( stack a b)", "(stack a b )", "(  STACK\ta   b  )"] {
        let line = model.validate_text(&spelling, &[text]).unwrap_err().describe(model.task());
        assert!(line.contains("((stack a b)) is not applicable: unmet (holding a)"), "{text}: {line}");
    }
    // An action id past the task's (another task's plan) is an unknown action, not a panic.
    let pick_up = spelling.parse("(pick-up a)")[0];
    let foreign = transition_model::ActionId::from_index(model.task().actions.len());
    let error = model.validate(&[pick_up, foreign]).unwrap_err();
    assert!(matches!(&error, PlanError::UnknownAction { step: 2, .. }), "{error:?}");
}

/// The decision tree finds exactly the actions a scan of every action finds, in every
/// state along the ALFWorld walkthroughs and the EAI gold plans, and along random walks in
/// the IPC tasks.
#[test]
fn successor_generator_agrees_with_a_full_scan() {
    let mut checked = 0;
    for benchmark in [Benchmark::AlfworldSeen, Benchmark::VirtualhomeEai, Benchmark::Ipc] {
        for (index, files) in load(benchmark).expect("fixtures load").into_iter().enumerate() {
            if benchmark == Benchmark::AlfworldSeen && index % 5 != 0 {
                continue;
            }
            let model = model(&files);
            let mut applicable = Vec::new();
            for state in model.random_walk(0x2545_F491_4F6C_DD1D ^ index as u64, 30) {
                model.applicable(&state, &mut applicable);
                applicable.sort();
                let scanned: Vec<_> = model.task().action_ids().filter(|&a| model.is_applicable(&state, a)).collect();
                assert_eq!(applicable, scanned, "{}", files.id);
                checked += 1;
            }
        }
    }
    assert!(checked > 5000, "{checked}");
}

/// Spelling both ways: every spelled action parses back to a set holding it, in all three
/// surface languages; and the EAI gold plans, rewritten in VirtualHome's class-level verbs,
/// still validate.
#[test]
fn spellings_round_trip_and_gold_plans_validate_in_virtualhome_verbs() {
    let mut spelled = 0;
    let mut rewritten = 0;
    for files in load(Benchmark::VirtualhomeEai).expect("fixtures load") {
        let model = model(&files);
        let pddl = Spelling::pddl(model.task());
        let verbs = Spelling::virtualhome(model.task());
        for spelling in [&pddl, &verbs] {
            for action in model.task().action_ids() {
                if let Some(text) = spelling.spell(action) {
                    assert!(spelling.parse(text).contains(&action), "{}: `{text}`", files.id);
                    spelled += 1;
                }
            }
        }
        let Extra::Virtualhome { gold_plan: Some(plan), .. } = &files.extra else { continue };
        let valid = model.validate_text(&pddl, plan).expect("gold plan validates");
        let in_verbs: Vec<&str> = valid.actions.iter().map(|&a| verbs.spell(a).expect("every gold step has a VirtualHome verb")).collect();
        let again =
            model.validate_text(&verbs, &in_verbs).unwrap_or_else(|e| panic!("{}: {in_verbs:?}: {}", files.id, e.describe(model.task())));
        assert_eq!(again.final_state, valid.final_state, "{}", files.id);
        rewritten += 1;
    }
    for files in load(Benchmark::AlfworldSeen).expect("fixtures load").into_iter().step_by(7) {
        let model = model(&files);
        let Extra::Alfworld(game) = &files.extra else { unreachable!() };
        let commands = Spelling::alfworld(model.task(), &game.grammar).expect("grammar");
        for action in model.task().action_ids() {
            let text = commands.spell(action).expect("every ALFWorld action has a command");
            assert!(commands.parse(text).contains(&action), "{}: `{text}`", files.id);
            spelled += 1;
        }
    }
    assert_eq!(rewritten, 296);
    println!("{spelled} spelled actions parse back; {rewritten} gold plans validate in VirtualHome verbs");
}

/// A broken grammar is named where it breaks: an `action` block without `{` at its byte in the
/// grammar, a template's unclosed placeholder by its action and its byte in the template.
#[test]
fn a_broken_alfworld_grammar_says_where() {
    use transition_model::SpellingError;
    let files = load(Benchmark::AlfworldSeen).expect("fixtures load").into_iter().next().expect("a task");
    let Extra::Alfworld(game) = &files.extra else { panic!("an ALFWorld game") };
    let model = model(&files);
    let unclosed = game.grammar.replacen("template :: \"open {r}\"", "template :: \"open {r\"", 1);
    assert_ne!(unclosed, game.grammar, "the fixture's grammar has the open template");
    match Spelling::alfworld(model.task(), &unclosed) {
        Err(SpellingError::UnclosedPlaceholder { action, offset }) => assert_eq!((action.as_str(), offset), ("openobject", 5)),
        other => panic!("{:?}", other.map(|_| ())),
    }
    // Cut just before an action block's `{`: that block is the one without a brace.
    let at = game.grammar.rfind("action ").expect("an action block");
    let cut = &game.grammar[..at + game.grammar[at..].find('{').expect("its brace")];
    match transition_model::alfworld::templates(cut) {
        Err(SpellingError::MalformedGrammar { offset, .. }) => assert_eq!(offset, at, "{}", &cut[offset..]),
        other => panic!("{:?}", other.map(|_| ())),
    }
}
