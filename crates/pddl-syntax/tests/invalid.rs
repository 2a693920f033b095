//! Each file in `fixtures/pddl-invalid/` shows one kind of error (its name starts with the
//! kind's code). The parser and checker must report that kind, at the right place, with a
//! message a person can act on: the full output is an insta snapshot.
//! Problems (`*.problem.pddl`) are checked against `fixtures/pddl-valid/household/domain.pddl`.

use std::path::Path;

use pddl_syntax::{Diagnostic, check, parse_domain, parse_domain_recovering, parse_problem_recovering};

fn fixtures() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures"))
}

/// Every diagnostic for one file, rendered as `name:line:column: severity[kind]: message`.
fn diagnose(path: &Path) -> (Vec<Diagnostic>, String) {
    let source = std::fs::read_to_string(path).expect("fixture readable");
    let name = path.file_name().unwrap_or_default().to_string_lossy().into_owned();
    let household = std::fs::read_to_string(fixtures().join("pddl-valid/household/domain.pddl")).expect("household domain");
    let household = parse_domain(&household).expect("household domain parses");
    let diagnostics = if name.ends_with(".problem.pddl") {
        let (problem, mut diagnostics) = parse_problem_recovering(&source);
        if let Some(problem) = problem {
            diagnostics.extend(check(&household, Some(&problem)).problem);
        }
        diagnostics
    } else {
        let (domain, mut diagnostics) = parse_domain_recovering(&source);
        if let Some(domain) = domain {
            diagnostics.extend(check(&domain, None).domain);
        }
        diagnostics
    };
    let rendered: Vec<String> = diagnostics.iter().map(|d| d.render(&name, &source)).collect();
    (diagnostics, rendered.join("\n"))
}

#[test]
fn invalid_fixtures_report_their_kind() {
    let mut paths: Vec<_> = std::fs::read_dir(fixtures().join("pddl-invalid")).expect("folder").map(|e| e.expect("entry").path()).collect();
    paths.sort();
    assert!(paths.len() >= 19);
    for path in paths {
        let name = path.file_name().unwrap_or_default().to_string_lossy().into_owned();
        let (diagnostics, rendered) = diagnose(&path);
        assert!(!diagnostics.is_empty(), "{name}: no diagnostic");
        let code = name.split('.').next().unwrap_or_default();
        if code != "many-errors" {
            assert!(diagnostics.iter().any(|d| d.kind.code() == code), "{name}: no `{code}` diagnostic in\n{rendered}");
        } else {
            assert!(diagnostics.len() >= 4, "{name}: the checker stops early:\n{rendered}");
        }
        insta::assert_snapshot!(code.to_string(), rendered);
    }
}

#[test]
fn the_household_world_is_clean() {
    let domain = std::fs::read_to_string(fixtures().join("pddl-valid/household/domain.pddl")).expect("domain");
    let problem = std::fs::read_to_string(fixtures().join("pddl-valid/household/problem.pddl")).expect("problem");
    let (domain, diagnostics) = parse_domain_recovering(&domain);
    assert_eq!(diagnostics, vec![]);
    let (problem, diagnostics) = parse_problem_recovering(&problem);
    assert_eq!(diagnostics, vec![]);
    let report = check(&domain.expect("domain"), problem.as_ref());
    assert!(report.domain.is_empty() && report.problem.is_empty(), "{report:?}");
}

/// Nesting as deep as a hostile or broken file can make it (100,000 `(not`) is an error at the
/// first list too deep, not a stack overflow in whatever reads the tree; nesting PDDL uses
/// parses as before.
#[test]
fn nesting_too_deep_is_an_error_not_a_crash() {
    let deep = |n: usize| {
        format!(
            "(define (domain d) (:requirements :negative-preconditions) (:predicates (p))\n(:action a :parameters () :precondition {}(p){} :effect (p)))",
            "(not ".repeat(n),
            ")".repeat(n)
        )
    };
    let (domain, diagnostics) = parse_domain_recovering(&deep(100_000));
    let too_deep: Vec<&Diagnostic> = diagnostics.iter().filter(|d| d.message.contains("nested more than")).collect();
    assert_eq!(too_deep.len(), 1, "{diagnostics:?}");
    let source = deep(100_000);
    let line = &source[..too_deep[0].span.start as usize];
    assert_eq!(line.matches('(').count() - line.matches(')').count(), pddl_syntax::MAX_DEPTH, "reported at the first `(` too deep");
    if let Some(domain) = domain {
        let _ = check(&domain, None);
    }
    assert!(parse_domain(&deep(40)).is_ok(), "40 levels of `not` is PDDL");
}

/// A parse that fails says its errors first: the first line of the message is what made it
/// fail, not a warning that came before it in the file.
#[test]
fn a_failed_parse_says_its_errors_before_its_warnings() {
    let source = "(define (domain d) (:requirements :durative-actions)\n (:durative-action a :parameters ()))\n";
    let error = pddl_syntax::parse_domain(source).expect_err("a durative action is outside the fragment");
    let rendered = error.render("d.pddl", source);
    let lines: Vec<&str> = rendered.lines().collect();
    assert!(lines.len() >= 2, "{rendered}");
    assert!(lines[0].contains(": error["), "{rendered}");
    assert!(lines.iter().any(|l| l.contains(": warning[")), "{rendered}");
}

#[test]
fn a_failed_parse_says_where_its_first_error_is_without_the_source() {
    let source = "(define (domain d)\n (:predicates (p ?x))\n (:action a :parameters (?x) :precondition (p ?x) :effect (p ?x))) (more)\n";
    let error = pddl_syntax::parse_domain(source).expect_err("text after the domain");
    let first = error.errors().next().unwrap();
    let (line, column) = pddl_syntax::line_column(source, first.span.start as usize);
    assert_eq!(line, 3);
    let shown = error.to_string();
    assert!(shown.contains(&format!("first at line 3, column {column}: ")), "{shown}");
    assert!(shown.contains(&first.message), "{shown}");
    // A library user's `?` keeps the message: the error is a std error.
    let boxed: Box<dyn std::error::Error> = Box::new(error);
    assert_eq!(boxed.to_string(), shown);
}

/// A key an action or a problem has once (`:parameters`, `:precondition`, `:effect`; `:domain`,
/// `:goal`, `:metric`) written twice is a `duplicate` error at the second, which used to
/// replace the first silently (a plan for the second precondition was "valid").
#[test]
fn a_second_precondition_effect_or_goal_is_an_error_not_a_replacement() {
    let domain = "(define (domain t) (:predicates (p) (q))\n\
                  (:action a :parameters () :precondition (p)\n  :precondition (and) :effect (q) :effect (and)))";
    let (_, diagnostics) = parse_domain_recovering(domain);
    let rendered: Vec<String> = diagnostics.iter().map(|d| d.render("d.pddl", domain)).collect();
    assert_eq!(
        rendered,
        [
            "d.pddl:3:3: error[duplicate]: action `a` has a second `:precondition`",
            "d.pddl:3:35: error[duplicate]: action `a` has a second `:effect`",
        ],
        "{rendered:#?}"
    );
    let problem = "(define (problem p) (:domain t) (:init)\n(:goal (p)) (:goal (q)))";
    let (_, diagnostics) = parse_problem_recovering(problem);
    let rendered: Vec<String> = diagnostics.iter().map(|d| d.render("p.pddl", problem)).collect();
    assert_eq!(rendered, ["p.pddl:2:13: error[duplicate]: the problem has a second `(:goal` section"], "{rendered:#?}");
}

/// Numeric input the planners would misread is an error at its place: a metric other than
/// minimising `(total-cost)` (a `maximize` was minimised), a cost of `(total-cost)` itself
/// (read as its initial value), and a function given two values in `:init` (the last one was
/// taken); the same value twice is a warning. Fast Downward refuses all three.
#[test]
fn numeric_input_the_planners_would_misread_is_an_error() {
    let domain = "(define (domain d) (:requirements :strips :action-costs)\n\
        (:predicates (p) (q ?x))\n\
        (:functions (total-cost) - number (dist ?x ?y) - number)\n\
        (:action a :parameters () :precondition () :effect (and (p) (increase (total-cost) (total-cost)))))\n";
    let (domain, diagnostics) = parse_domain_recovering(domain);
    assert!(diagnostics.is_empty(), "{diagnostics:?}");
    let domain = domain.expect("parses");
    let found = check(&domain, None).domain;
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].is_error() && found[0].message.contains("cannot be `(total-cost)` itself"), "{found:?}");

    let problem = |init: &str, metric: &str| format!("(define (problem p) (:domain d) (:objects a b) (:init {init}) (:goal (p)) {metric})");
    let findings = |text: &str| {
        let (problem, diagnostics) = parse_problem_recovering(text);
        assert!(diagnostics.is_empty(), "{diagnostics:?}");
        let report = check(&domain, Some(&problem.expect("parses"))).problem;
        report
            .iter()
            .map(|d| (d.is_error(), d.message.clone(), text[d.span.start as usize..d.span.end as usize].to_string()))
            .collect::<Vec<_>>()
    };
    let found = findings(&problem("(= (total-cost) 0)", "(:metric maximize (total-cost))"));
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].0 && found[0].1.contains("the supported metric is `(:metric minimize (total-cost))`"), "{found:?}");
    assert_eq!(found[0].2, "(:metric maximize (total-cost))");
    assert!(findings(&problem("(= (dist a b) 2)", "(:metric minimize (dist a b))"))[0].1.contains("the supported metric"));
    assert!(findings(&problem("(= (total-cost) 0)", "(:metric minimize (total-cost))")).is_empty());

    let found = findings(&problem("(= (dist a b) 1) (= (dist a b) 5) (= (dist b a) 2) (= (dist b a) 2)", ""));
    assert_eq!(found.len(), 2, "{found:?}");
    assert_eq!(found[0], (true, "`(dist a b)` is given two values, 1 and then 5".to_string(), "(= (dist a b) 5)".to_string()));
    assert_eq!(found[1], (false, "`(dist b a)` is given its value twice".to_string(), "(= (dist b a) 2)".to_string()));
}

/// Forms in the wrong place say what they are and where they go: an effect in a condition, a
/// condition in an effect (both read "expected a variable or constant, found `(free ...)`"),
/// a variable the goal does not bind (it read "not a parameter of the action"), and a control
/// character (a NUL byte read "found ``").
#[test]
fn forms_in_the_wrong_place_say_what_they_are() {
    let domain = |pre: &str, effect: &str| {
        format!("(define (domain d) (:predicates (p) (q ?x)) (:action a :parameters (?x) :precondition {pre} :effect {effect}))")
    };
    let first = |text: &str| parse_domain_recovering(text).1.first().map(|d| d.message.clone()).unwrap_or_default();
    assert_eq!(first(&domain("(when (p) (q ?x))", "(p)")), "`(when ...)` is an effect, not a condition: it goes in the action's `:effect`");
    assert!(first(&domain("(and (p) (increase (total-cost) 1))", "(p)")).starts_with("`(increase ...)` is an effect, not a condition"));
    assert!(first(&domain("(p)", "(imply (p) (q ?x))")).starts_with("`(imply ...)` is a condition, not an effect: an effect that depends"));
    assert!(first(&domain("(p)", "(or (p) (q ?x))")).starts_with("`(or ...)` is a condition, not an effect"));
    let nul = "(define (domain d) (:predicates (p)) \u{0} (:action a :parameters () :precondition (p) :effect (p)))";
    assert_eq!(first(nul), "expected a section such as `(:predicates ...)`, found `\\0`");

    let household = std::fs::read_to_string(fixtures().join("pddl-valid/household/domain.pddl")).expect("household domain");
    let household = parse_domain(&household).expect("household domain parses");
    let (problem, diagnostics) = parse_problem_recovering("(define (problem e) (:domain household) (:init) (:goal (holding ?x)))");
    assert!(diagnostics.is_empty(), "{diagnostics:?}");
    let found = check(&household, Some(&problem.expect("parses"))).problem;
    assert!(
        found.iter().any(|d| d.message == "variable `?x` is not bound by an enclosing `forall` or `exists` (the goal names objects)"),
        "{found:?}"
    );
}
