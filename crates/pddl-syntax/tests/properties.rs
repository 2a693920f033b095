//! Laws of the parser and printer, on generated trees and on mutated real files:
//! printing then parsing is the identity, and no input makes the parser panic.

use pddl_syntax::*;
use proptest::prelude::*;

const KEYWORDS: &[&str] = &[
    "and",
    "or",
    "not",
    "imply",
    "exists",
    "forall",
    "when",
    "increase",
    "decrease",
    "assign",
    "scale-up",
    "scale-down",
    "either",
    "define",
    "domain",
    "problem",
    "at",
    "minimize",
    "maximize",
];

fn name() -> impl Strategy<Value = Name> {
    "[a-z][a-z0-9_-]{0,5}".prop_filter("not a keyword", |s| !KEYWORDS.contains(&s.as_str())).prop_map(Name::new)
}

fn ty() -> impl Strategy<Value = Type> {
    prop_oneof![name().prop_map(Type::Named), prop::collection::vec(name(), 1..3).prop_map(Type::Either)]
}

/// A typed list as the grammar allows it: untyped entries only at the end.
fn typed_list() -> impl Strategy<Value = Vec<TypedName>> {
    (prop::collection::vec((name(), ty()), 0..4), prop::collection::vec(name(), 0..3)).prop_map(|(typed, untyped)| {
        typed
            .into_iter()
            .map(|(name, ty)| TypedName { name, ty: Some(ty) })
            .chain(untyped.into_iter().map(|name| TypedName { name, ty: None }))
            .collect()
    })
}

fn term() -> impl Strategy<Value = Term> {
    prop_oneof![name().prop_map(Term::Variable), name().prop_map(Term::Constant)]
}

fn atom() -> impl Strategy<Value = Atom> {
    (name(), prop::collection::vec(term(), 0..3)).prop_map(|(predicate, args)| Atom { predicate, args, span: Span::default() })
}

fn ground_atom() -> impl Strategy<Value = Atom> {
    (name(), prop::collection::vec(name().prop_map(Term::Constant), 0..3)).prop_map(|(predicate, args)| Atom {
        predicate,
        args,
        span: Span::default(),
    })
}

fn condition() -> impl Strategy<Value = Condition> {
    let leaf = prop_oneof![atom().prop_map(Condition::Atom), (term(), term()).prop_map(|(a, b)| Condition::Equals(a, b, Span::default()))];
    leaf.prop_recursive(4, 24, 4, |inner| {
        prop_oneof![
            inner.clone().prop_map(|c| Condition::Not(Box::new(c), Span::default())),
            prop::collection::vec(inner.clone(), 0..4).prop_map(|c| Condition::And(c, Span::default())),
            prop::collection::vec(inner.clone(), 0..4).prop_map(|c| Condition::Or(c, Span::default())),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| Condition::Imply(Box::new(a), Box::new(b), Span::default())),
            (typed_list(), inner.clone()).prop_map(|(v, c)| Condition::Exists(v, Box::new(c), Span::default())),
            (typed_list(), inner).prop_map(|(v, c)| Condition::Forall(v, Box::new(c), Span::default())),
        ]
    })
}

fn number() -> impl Strategy<Value = Number> {
    (0u32..1000, 0u32..4).prop_map(|(n, quarter)| Number { value: f64::from(n) + f64::from(quarter) / 4.0, span: Span::default() })
}

fn function_term() -> impl Strategy<Value = FunctionTerm> {
    (name(), prop::collection::vec(term(), 0..2)).prop_map(|(function, args)| FunctionTerm { function, args, span: Span::default() })
}

fn effect() -> impl Strategy<Value = Effect> {
    let leaf = prop_oneof![
        atom().prop_map(Effect::Add),
        atom().prop_map(|a| Effect::Delete(a, Span::default())),
        (function_term(), prop_oneof![number().prop_map(NumericExpr::Number), function_term().prop_map(NumericExpr::Function)])
            .prop_map(|(f, v)| Effect::Increase(f, v, Span::default())),
    ];
    leaf.prop_recursive(3, 16, 4, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..4).prop_map(|e| Effect::And(e, Span::default())),
            (typed_list(), inner.clone()).prop_map(|(v, e)| Effect::Forall(v, Box::new(e), Span::default())),
            (condition(), inner).prop_map(|(c, e)| Effect::When(c, Box::new(e), Span::default())),
        ]
    })
}

fn requirements() -> impl Strategy<Value = Vec<Name>> {
    prop::collection::vec(
        prop::sample::select(vec!["strips", "typing", "adl", "equality", "action-costs", "conditional-effects"]).prop_map(Name::new),
        0..3,
    )
}

fn domain() -> impl Strategy<Value = Domain> {
    let action = (name(), typed_list(), prop::option::of(condition()), prop::option::of(effect())).prop_map(
        |(name, params, precondition, effect)| Action {
            name,
            params: params.into_iter().collect(),
            precondition,
            effect,
            span: Span::default(),
        },
    );
    let function = (name(), typed_list(), prop::option::of(ty()));
    (
        name(),
        requirements(),
        typed_list(),
        typed_list(),
        prop::collection::vec((name(), typed_list()).prop_map(|(name, params)| PredicateDecl { name, params }), 0..4),
        prop::collection::vec(function, 0..3),
        prop::collection::vec(action, 0..3),
    )
        .prop_map(|(name, requirements, types, constants, predicates, functions, actions)| {
            // Like typed lists, untyped functions may only come last.
            let mut functions: Vec<FunctionDecl> =
                functions.into_iter().map(|(name, params, ty)| FunctionDecl { name, params, ty }).collect();
            functions.sort_by_key(|f| f.ty.is_none());
            Domain { name, requirements, types, constants, predicates, functions, actions, span: Span::default() }
        })
}

fn problem() -> impl Strategy<Value = Problem> {
    let init = prop_oneof![
        ground_atom().prop_map(InitElement::Atom),
        (name(), prop::collection::vec(name().prop_map(Term::Constant), 0..2), number()).prop_map(|(function, args, value)| {
            InitElement::Assign(FunctionTerm { function, args, span: Span::default() }, value, Span::default())
        }),
    ];
    (
        name(),
        name(),
        requirements(),
        typed_list(),
        prop::collection::vec(init, 0..6),
        prop::option::of(condition()),
        prop::option::of(function_term()),
    )
        .prop_map(|(name, domain, requirements, objects, init, goal, metric)| Problem {
            name,
            domain,
            requirements,
            objects,
            init,
            goal: Some(goal.unwrap_or(Condition::And(Vec::new(), Span::default()))),
            metric: metric.map(|f| Metric { optimization: Optimization::Minimize, expr: NumericExpr::Function(f), span: Span::default() }),
            span: Span::default(),
        })
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        rng_seed: proptest::test_runner::RngSeed::Fixed(2561),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn printed_domains_parse_back_to_the_same_tree(domain in domain()) {
        let printed = domain.to_string();
        let parsed = parse_domain(&printed).map_err(|e| TestCaseError::fail(format!("{}\n{printed}", e.render("printed", &printed))))?;
        prop_assert_eq!(parsed, domain);
    }

    #[test]
    fn printed_problems_parse_back_to_the_same_tree(problem in problem()) {
        let printed = problem.to_string();
        let parsed = parse_problem(&printed).map_err(|e| TestCaseError::fail(format!("{}\n{printed}", e.render("printed", &printed))))?;
        prop_assert_eq!(parsed, problem);
    }
}

/// Small real files to mutate: the household world and every IPC domain and first instance.
fn seeds() -> &'static [String] {
    static SEEDS: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
    SEEDS.get_or_init(read_seeds)
}

fn read_seeds() -> Vec<String> {
    let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures"));
    let mut out = Vec::new();
    for path in ["pddl-valid/household/domain.pddl", "pddl-valid/household/problem.pddl", "virtualhome-eai/virtualhome.pddl"] {
        out.push(std::fs::read_to_string(root.join(path)).expect("seed"));
    }
    for dir in ["blocks", "gripper", "logistics00", "miconic", "elevators-opt08", "driverlog", "visitall-opt11"] {
        out.push(std::fs::read_to_string(root.join("ipc").join(dir).join("domain.pddl")).expect("seed"));
        let dir = root.join("ipc").join(dir);
        let mut instances: Vec<_> = std::fs::read_dir(&dir)
            .expect("ipc dir")
            .map(|e| e.expect("entry").path())
            .filter(|p| p.to_string_lossy().contains("instance-"))
            .collect();
        instances.sort();
        out.push(std::fs::read_to_string(&instances[0]).expect("seed"));
    }
    out
}

#[derive(Debug, Clone)]
enum Mutation {
    Truncate(usize),
    Delete(usize, usize),
    Insert(usize, &'static str),
    Duplicate(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), 1usize..40).prop_map(|(at, len)| Mutation::Delete(at, len)),
        (
            any::<usize>(),
            prop::sample::select(vec![
                "(", ")", "?", "-", ":action", "(and", "(not", " - ", "(either", "(= ?x", "1e999", ";", "é", "(:types"
            ])
        )
            .prop_map(|(at, text)| Mutation::Insert(at, text)),
        (any::<usize>(), 1usize..60).prop_map(|(at, len)| Mutation::Duplicate(at, len)),
    ]
}

fn apply(text: &str, mutations: &[Mutation]) -> String {
    let mut bytes = text.as_bytes().to_vec();
    for mutation in mutations {
        let len = bytes.len().max(1);
        match *mutation {
            Mutation::Truncate(at) => bytes.truncate(at % len),
            Mutation::Delete(at, n) => {
                let at = at % len;
                bytes.drain(at..(at + n).min(bytes.len()));
            }
            Mutation::Insert(at, inserted) => {
                let at = at % len;
                bytes.splice(at.min(bytes.len())..at.min(bytes.len()), inserted.bytes());
            }
            Mutation::Duplicate(at, n) => {
                let at = at % len;
                let piece: Vec<u8> = bytes[at.min(bytes.len())..(at + n).min(bytes.len())].to_vec();
                bytes.splice(at.min(bytes.len())..at.min(bytes.len()), piece);
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 512,
        rng_seed: proptest::test_runner::RngSeed::Fixed(5121),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    /// Mutated real files never make the parser or checker panic, and every diagnostic
    /// points inside the text and renders with a line and column.
    #[test]
    fn mutated_files_get_diagnostics_not_panics(seed in 0usize..17, mutations in prop::collection::vec(mutation(), 1..4)) {
        let seeds = seeds();
        let text = apply(&seeds[seed % seeds.len()], &mutations);
        let (domain, mut diagnostics) = parse_domain_recovering(&text);
        let (problem, problem_diagnostics) = parse_problem_recovering(&text);
        diagnostics.extend(problem_diagnostics);
        if let Some(domain) = &domain {
            let report = check(domain, problem.as_ref());
            diagnostics.extend(report.domain);
            diagnostics.extend(report.problem);
        }
        for diagnostic in &diagnostics {
            prop_assert!(diagnostic.span.end as usize <= text.len());
            prop_assert!(diagnostic.render("f", &text).starts_with("f:"));
            prop_assert!(!diagnostic.message.is_empty());
        }
    }
}

/// The configs above keep failures beside this file: `WithSource` swaps `.rs` for
/// `.proptest-regressions`, so `tests/properties.proptest-regressions` (committed) is read and
/// its cases are replayed before novel ones. Renaming either file breaks that silently; this
/// does not.
#[test]
fn the_kept_regressions_are_found_and_read() {
    use proptest::test_runner::{FailurePersistence, FileFailurePersistence};
    let seeds = FileFailurePersistence::WithSource("proptest-regressions").load_persisted_failures2(Some(file!()));
    assert!(!seeds.is_empty(), "{} has no readable `cc` line beside it", file!());
}

/// `Eq` and `Hash` agree on numbers: `0` and `-0` are equal, so they hash alike, and trees that
/// differ only there are one key of a hash map.
#[test]
fn equal_numbers_hash_alike() {
    use std::hash::BuildHasher;
    let hasher = std::collections::hash_map::RandomState::new();
    let zero = pddl_syntax::Number { value: 0.0, span: pddl_syntax::Span::default() };
    let negative_zero = pddl_syntax::Number { value: -0.0, span: pddl_syntax::Span::new(3, 5) };
    assert_eq!(zero, negative_zero);
    assert_eq!(hasher.hash_one(&zero), hasher.hash_one(&negative_zero));
}
