//! Snapshots of the texts the transition model writes for people and models, where the text
//! is the contract: plan validation's verdicts (`describe` and `Display`) for valid plans and
//! for each kind of invalid one (unknown action, inapplicable step with its unmet
//! preconditions, goal not reached with the unmet goal part, a clause, an unreachable goal),
//! and one plan in its three spellings (PDDL, ALFWorld commands, VirtualHome verbs) beside
//! the real ALFWorld walkthrough and EAI gold plan in the spellings their tasks have.

use std::fmt::Write;

use benchmark_data::{Benchmark, Extra, TaskFiles, load};
use transition_model::{Spelling, TransitionModel};

/// The task `id`, or the first whose id starts with `id` when it ends with `/` (an ALFWorld
/// game folder without its trial).
fn find(benchmark: Benchmark, id: &str) -> TaskFiles {
    let matches = |t: &TaskFiles| t.id == id || (id.ends_with('/') && t.id.starts_with(id));
    load(benchmark).expect("fixtures load").into_iter().find(matches).unwrap_or_else(|| panic!("no fixture {id}"))
}

fn model_of(domain: &str, problem: &str) -> TransitionModel {
    let domain = pddl_syntax::parse_domain(domain).expect("domain parses");
    let problem = pddl_syntax::parse_problem(problem).expect("problem parses");
    TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"))
}

fn model(files: &TaskFiles) -> TransitionModel {
    model_of(&files.domain, &files.problem)
}

/// The verdict on `plan` as validation writes it: `valid: ...`, or `describe` then `Display`.
fn verdict(out: &mut String, model: &TransitionModel, spelling: &Spelling, plan: &[&str]) {
    writeln!(out, "plan ({}): {}", spelling.language().name(), if plan.is_empty() { "(empty)".to_string() } else { plan.join(" | ") })
        .unwrap();
    match model.validate_text(spelling, plan) {
        Ok(valid) => {
            let actions: Vec<String> = valid.actions.iter().map(|&a| model.task().action_name(a)).collect();
            writeln!(out, "  valid: {} steps, cost {}: {}", valid.actions.len(), valid.cost, actions.join(" ")).unwrap();
        }
        Err(error) => {
            writeln!(out, "  {}", error.describe(model.task())).unwrap();
            writeln!(out, "  ({error})").unwrap();
        }
    }
}

#[test]
fn validation_verdicts() {
    let mut out = String::new();

    let blocks = model(&find(Benchmark::Ipc, "blocks/instance-1"));
    let pddl = Spelling::pddl(blocks.task());
    writeln!(out, "== blocks/instance-1: goal (on d c) (on c b) (on b a)").unwrap();
    for plan in [
        &["(pick-up b)", "(stack b a)", "(pick-up c)", "(stack c b)", "(pick-up d)", "(stack d c)"][..],
        // Spellings are normalised: case, white space, PDDL parentheses.
        &["PICK-UP  b", "(stack B a)", "pick-up c", "  (stack c b) ", "(pick-up d)", "stack d c"],
        &["(pick-up b)", "(fly-away b)"],
        &["(stack a b)"],
        &["(pick-up b)", "(unstack c d)"],
        &["(pick-up b)", "(stack b a)", "(pick-up b)"],
        &["(pick-up b)", "(stack b a)"],
        &[],
    ] {
        verdict(&mut out, &blocks, &pddl, plan);
    }

    let household = benchmark_data::fixtures_dir().join("pddl-valid/household/domain.pddl");
    let household = std::fs::read_to_string(household).expect("household domain");
    let closed = model_of(
        &household,
        "(define (problem p) (:domain household) (:objects kitchentable - place dishwasher - container wineglass - item)
         (:init (at kitchentable) (on wineglass kitchentable) (handempty)) (:goal (closed dishwasher)))",
    );
    writeln!(out, "\n== household, goal (closed dishwasher), which no action adds").unwrap();
    verdict(&mut out, &closed, &Spelling::pddl(closed.task()), &["(walk kitchentable dishwasher)"]);

    let files = find(Benchmark::AlfworldSeen, "look_at_obj_in_light-AlarmClock-None-DeskLamp-323/");
    let Extra::Alfworld(game) = &files.extra else { unreachable!("ALFWorld tasks carry their game") };
    let alfworld = model(&files);
    let commands = Spelling::alfworld(alfworld.task(), &game.grammar).expect("grammar");
    let walkthrough: Vec<&str> = game.walkthrough.iter().map(String::as_str).collect();
    writeln!(out, "\n== {}: walkthrough {}", files.id, walkthrough.join(" | ")).unwrap();
    for plan in
        [walkthrough.clone(), walkthrough[1..].to_vec(), walkthrough[..2].to_vec(), vec![walkthrough[0], "take alarmclock 9 from desk 1"]]
    {
        verdict(&mut out, &alfworld, &commands, &plan);
    }

    let files = find(Benchmark::VirtualhomeEai, "7_1");
    let Extra::Virtualhome { gold_plan: Some(gold), .. } = &files.extra else { panic!("7_1 has a gold plan") };
    let eai = model(&files);
    let verbs = Spelling::virtualhome(eai.task());
    let in_verbs: Vec<String> = eai
        .validate_text(&Spelling::pddl(eai.task()), gold)
        .expect("the gold plan validates")
        .actions
        .iter()
        .map(|&a| verbs.spell(a).expect("a verb").to_string())
        .collect();
    let in_verbs: Vec<&str> = in_verbs.iter().map(String::as_str).collect();
    writeln!(out, "\n== EAI 7_1 (browse the internet): the gold plan in VirtualHome verbs, and with two steps swapped").unwrap();
    verdict(&mut out, &eai, &verbs, &in_verbs);
    let mut swapped = in_verbs.clone();
    let plug_in = swapped.iter().position(|&t| t == "plugin computer").expect("the gold plan plugs the computer in");
    swapped.swap(plug_in, plug_in + 1);
    verdict(&mut out, &eai, &verbs, &swapped);

    insta::assert_snapshot!(out);
}

/// A small home whose schemas are EAI's, so that VirtualHome verbs spell it, with a TextWorld
/// grammar for the ALFWorld commands: one plan in all three spellings.
const HOME_DOMAIN: &str = "(define (domain home) (:requirements :strips :typing)
  (:types character object)
  (:predicates (next_to ?c - character ?o - object) (holds ?c - character ?o - object) (handsfree ?c - character)
               (closed ?o - object) (inside ?o - object ?r - object) (in_room ?c - character ?r - object) (room ?r - object)
               (container ?o - object) (grabbable ?o - object))
  (:action walk_into :parameters (?c - character ?r - object) :precondition (room ?r) :effect (in_room ?c ?r))
  (:action walk_towards :parameters (?c - character ?o - object) :precondition (not (room ?o)) :effect (next_to ?c ?o))
  (:action open :parameters (?c - character ?o - object) :precondition (and (next_to ?c ?o) (container ?o) (closed ?o))
     :effect (not (closed ?o)))
  (:action grab :parameters (?c - character ?o - object) :precondition (and (next_to ?c ?o) (grabbable ?o) (handsfree ?c))
     :effect (and (holds ?c ?o) (not (handsfree ?c))))
  (:action put_inside :parameters (?c - character ?o - object ?r - object)
     :precondition (and (holds ?c ?o) (next_to ?c ?r) (container ?r) (not (closed ?r)))
     :effect (and (inside ?o ?r) (handsfree ?c) (not (holds ?c ?o)))))";

const HOME_PROBLEM: &str = "(define (problem milk-in-fridge) (:domain home)
  (:objects me - character kitchen milk fridge - object)
  (:init (room kitchen) (handsfree me) (container fridge) (closed fridge) (grabbable milk))
  (:goal (inside milk fridge)))";

const HOME_GRAMMAR: &str = "
action walk_into {
    template :: \"go to {r}\";
}

action walk_towards {
    template :: \"go to [{o.name | next_to(c:character, o:object)}]\";
}

action open {
    template :: \"open {o}\";
}

action grab {
    template :: \"take {o}\";
}

action put_inside {
    template :: \"move {o} to {r}\";
}
";

#[test]
fn one_plan_in_three_spellings_and_real_plans_in_theirs() {
    let mut out = String::new();
    let home = model_of(HOME_DOMAIN, HOME_PROBLEM);
    let task = home.task();
    let pddl = Spelling::pddl(task);
    let names: Vec<Option<String>> = task.objects.iter().map(|o| (o.name != "me").then(|| format!("{} 1", o.name))).collect();
    let commands = Spelling::alfworld_with_names(task, HOME_GRAMMAR, names).expect("grammar");
    let verbs = Spelling::virtualhome(task);
    let plan = [
        "(walk_into me kitchen)",
        "(walk_towards me milk)",
        "(grab me milk)",
        "(walk_towards me fridge)",
        "(open me fridge)",
        "(put_inside me milk fridge)",
    ];
    let valid = home.validate_text(&pddl, &plan).expect("the plan validates");
    writeln!(out, "== one plan, three spellings (a small home with EAI's schemas and a TextWorld grammar)").unwrap();
    writeln!(out, "{:<28} | {:<24} | virtualhome", "pddl", "alfworld").unwrap();
    for &action in &valid.actions {
        let spell = |s: &Spelling| s.spell(action).unwrap_or("-").to_string();
        writeln!(out, "{:<28} | {:<24} | {}", spell(&pddl), spell(&commands), spell(&verbs)).unwrap();
    }
    // Each spelling of the plan validates to the same actions.
    for spelling in [&commands, &verbs] {
        let texts: Vec<&str> = valid.actions.iter().map(|&a| spelling.spell(a).expect("spelled")).collect();
        let again = home.validate_text(spelling, &texts).unwrap_or_else(|e| panic!("{}", e.describe(task)));
        assert_eq!(again.actions, valid.actions, "{} spelling", spelling.language().name());
    }

    let files = find(Benchmark::AlfworldSeen, "pick_and_place_simple-ToiletPaper-None-ToiletPaperHanger-406/");
    let Extra::Alfworld(game) = &files.extra else { unreachable!("ALFWorld tasks carry their game") };
    let alfworld = model(&files);
    let commands = Spelling::alfworld(alfworld.task(), &game.grammar).expect("grammar");
    let pddl = Spelling::pddl(alfworld.task());
    let verbs = Spelling::virtualhome(alfworld.task());
    let valid = alfworld.validate_text(&commands, &game.walkthrough).expect("the walkthrough wins");
    writeln!(out, "\n== {}: the walkthrough (VirtualHome verbs spell no ALFWorld schema)", files.id).unwrap();
    for &action in &valid.actions {
        assert_eq!(verbs.spell(action), None);
        writeln!(out, "{}\n    {}", commands.spell(action).expect("command"), pddl.spell(action).expect("pddl")).unwrap();
    }

    let files = find(Benchmark::VirtualhomeEai, "7_1");
    let Extra::Virtualhome { gold_plan: Some(gold), .. } = &files.extra else { panic!("7_1 has a gold plan") };
    let eai = model(&files);
    let pddl = Spelling::pddl(eai.task());
    let verbs = Spelling::virtualhome(eai.task());
    let valid = eai.validate_text(&pddl, gold).expect("the gold plan validates");
    writeln!(out, "\n== EAI 7_1: the gold plan (no TextWorld grammar for EAI's domain)").unwrap();
    writeln!(out, "{:<42} | virtualhome", "pddl").unwrap();
    for &action in &valid.actions {
        writeln!(out, "{:<42} | {}", pddl.spell(action).expect("pddl"), verbs.spell(action).expect("verb")).unwrap();
    }
    insta::assert_snapshot!(out);
}
