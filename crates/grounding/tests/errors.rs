//! Errors past the name check say where they are: the file they are about and the line and
//! column there.

use grounding::{GroundingError, PddlFile};

fn ground(domain: &str, problem: &str) -> GroundingError {
    let d = pddl_syntax::parse_domain(domain).expect("the domain parses");
    let p = pddl_syntax::parse_problem(problem).expect("the problem parses");
    grounding::ground(&d, &p).expect_err("grounding fails")
}

fn render(error: &GroundingError, domain: &str, problem: &str) -> String {
    error.render(("d.pddl", domain), ("p.pddl", problem))
}

const ROADS: &str = "(define (domain roads) (:requirements :strips :typing :action-costs)\n\
    (:types place)\n\
    (:predicates (at ?p - place))\n\
    (:functions (distance ?a ?b - place) - number (total-cost) - number)\n\
    (:action drive :parameters (?a ?b - place)\n\
      :precondition (at ?a)\n\
      :effect (and (not (at ?a)) (at ?b) (increase (total-cost) (distance ?a ?b)))))\n";

#[test]
fn a_cost_that_init_does_not_give_points_at_the_domain_s_cost_term() {
    let problem = "(define (problem p) (:domain roads) (:objects x y - place)\n\
        (:init (at x) (= (distance x y) 3) (= (distance x x) 0) (= (distance y y) 0))\n\
        (:goal (at y)) (:metric minimize (total-cost)))\n";
    let error = ground(ROADS, problem);
    assert!(matches!(&error, GroundingError::MissingCost { term, .. } if term == "(distance y x)"), "{error:?}");
    // `(distance ?a ?b)` on the domain's seventh line, column 59 (a continued string drops
    // the next line's indentation).
    assert_eq!(
        render(&error, ROADS, problem),
        "d.pddl:7:59: action (drive y x): its cost (distance y x) has no value in the problem's `:init`"
    );
}

#[test]
fn a_negative_cost_points_at_the_init_entry_that_gives_it() {
    let problem = "(define (problem p) (:domain roads) (:objects x y - place)\n\
        (:init (at x)\n\
          (= (distance x y) 3) (= (distance y x) -2) (= (distance x x) 0) (= (distance y y) 0))\n\
        (:goal (at y)) (:metric minimize (total-cost)))\n";
    let error = ground(ROADS, problem);
    assert_eq!(error.location().map(|(file, _)| file), Some(PddlFile::Problem), "{error:?}");
    assert_eq!(render(&error, ROADS, problem), "p.pddl:3:22: action (drive y x): cost -2 is not a whole number from 0 to 4294967295");
}

#[test]
fn a_fractional_number_cost_points_at_the_number_in_the_domain() {
    let domain = ROADS.replace("(distance ?a ?b)))))", "2.5))))");
    let problem = "(define (problem p) (:domain roads) (:objects x y - place)\n\
        (:init (at x)) (:goal (at y)) (:metric minimize (total-cost)))\n";
    let error = ground(&domain, problem);
    let rendered = render(&error, &domain, problem);
    assert!(rendered.starts_with("d.pddl:7:59: action (drive "), "{rendered}");
    assert!(rendered.ends_with("cost 2.5 is not a whole number from 0 to 4294967295"), "{rendered}");
    // A whole number past the limit is named as such (it read "not a non-negative integer").
    let domain = ROADS.replace("(distance ?a ?b)))))", "4294967296))))");
    let rendered = render(&ground(&domain, problem), &domain, problem);
    assert!(rendered.ends_with("cost 4294967296 is not a whole number from 0 to 4294967295"), "{rendered}");
}

#[test]
fn increasing_another_function_points_at_the_increase() {
    let domain = "(define (domain d) (:requirements :strips :numeric-fluents) (:predicates (p) (q))\n\
        (:functions (fuel) - number)\n\
        (:action burn :parameters () :precondition (p)\n\
          :effect (and (q) (increase (fuel) 1))))\n";
    let problem = "(define (problem e) (:domain d) (:init (p) (= (fuel) 0)) (:goal (q)))\n";
    let error = ground(domain, problem);
    assert_eq!(
        render(&error, domain, problem),
        "d.pddl:4:18: unsupported: action `burn` increases `fuel`; only `total-cost` can be increased"
    );
}

#[test]
fn a_goal_of_too_many_alternatives_points_at_the_goal() {
    // Thirteen disjunctions of two conjunctions (a disjunction of literals alone is kept as
    // one clause), over atoms an action can make true: 8192 alternatives.
    let predicates: String = (0..13).map(|i| format!("(a{i}) (b{i}) (c{i}) (d{i}) ")).collect();
    let domain = format!(
        "(define (domain d) (:requirements :strips :disjunctive-preconditions) (:predicates {predicates})\n\
         (:action all :parameters () :precondition (and) :effect (and {predicates})))\n"
    );
    let goal: String = (0..13).map(|i| format!("(or (and (a{i}) (b{i})) (and (c{i}) (d{i}))) ")).collect();
    let problem = format!("(define (problem e) (:domain d)\n  (:init)\n  (:goal (and {goal})))\n");
    let error = ground(&domain, &problem);
    assert_eq!(error.location().map(|(file, _)| file), Some(PddlFile::Problem), "{error:?}");
    let rendered = render(&error, &domain, &problem);
    assert!(rendered.starts_with("p.pddl:3:10: the goal splits into more than 4096 alternatives"), "{rendered}");
}

#[test]
fn names_that_do_not_check_render_each_in_its_file() {
    let domain =
        "(define (domain d) (:requirements :strips) (:predicates (p))\n  (:action a :parameters () :precondition (r) :effect (p)))\n";
    let problem = "(define (problem e) (:domain d)\n  (:init (s)) (:goal (p)))\n";
    let error = ground(domain, problem);
    let rendered = render(&error, domain, problem);
    let lines: Vec<&str> = rendered.lines().collect();
    assert_eq!(lines.len(), 2, "{rendered}");
    assert!(lines[0].starts_with("d.pddl:2:44: error[unknown-predicate]: predicate `r`"), "{rendered}");
    assert!(lines[1].starts_with("p.pddl:2:11: error[unknown-predicate]: predicate `s`"), "{rendered}");
}

/// A constant of the domain's actions that neither file declares is found in the problem pass
/// (the problem may declare it, as ALFWorld's problems declare `SinkType`), but it is an error in
/// the domain's text, and is shown there.
#[test]
fn a_domain_constant_neither_file_declares_is_shown_in_the_domain() {
    let domain = "(define (domain d) (:requirements :strips) (:predicates (p ?x))\n  (:action a :parameters () :precondition (p sink) :effect (p other)))\n";
    let problem = "(define (problem e) (:domain d) (:objects other)\n  (:init) (:goal (p other)))\n";
    let error = ground(domain, problem);
    assert_eq!(
        render(&error, domain, problem),
        "d.pddl:2:46: error[unknown-object]: action `a` names `sink`, which is declared neither in the domain's `:constants` nor in the problem's `:objects`"
    );
}

/// A type every object of a list is declared with is one error, said once: the checker finds it
/// for each object, at the same place.
#[test]
fn an_error_found_once_per_object_at_one_place_is_said_once() {
    let problem = "(define (problem p) (:domain roads)\n (:objects x y z - town)\n (:init (at x)) (:goal (at y)))\n";
    let error = ground(ROADS, problem);
    let rendered = render(&error, ROADS, problem);
    assert_eq!(rendered.lines().count(), 1, "{rendered}");
    assert!(rendered.starts_with("p.pddl:2:20: error[unknown-type]: type `town`"), "{rendered}");
}
