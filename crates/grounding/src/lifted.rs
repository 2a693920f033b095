//! The lifted task: types compiled into object domains, formulas in negation normal form
//! over numbered variables, effects flattened into (quantified, conditional) literals.

use rustc_hash::FxHashMap;

use pddl_syntax as ast;

use crate::GroundingError;
use crate::ids::{ObjectId, PredicateId};
use crate::task::{Object, Predicate};

/// A schema-local variable.
pub(crate) type Var = u32;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Arg {
    Var(Var),
    Obj(ObjectId),
}

#[derive(Debug, Clone)]
pub(crate) struct LiftedAtom {
    pub predicate: PredicateId,
    pub args: Vec<Arg>,
}

/// A formula in negation normal form. Quantified variables are fresh schema variables.
#[derive(Debug, Clone)]
pub(crate) enum Formula {
    True,
    Atom {
        negated: bool,
        atom: LiftedAtom,
    },
    Eq {
        negated: bool,
        a: Arg,
        b: Arg,
    },
    And(Vec<Formula>),
    Or(Vec<Formula>),
    /// The relaxed conjunctions of the body ([`relaxed_dnf`]) are kept to enumerate only
    /// bindings that can make the body true.
    Exists(Vec<Var>, Box<Formula>, Vec<RelaxedConj>),
    Forall(Vec<Var>, Box<Formula>),
}

/// A conjunction of positive atoms and (in)equalities: what a formula needs in the delete
/// relaxation, where negative literals are assumed satisfiable.
#[derive(Debug, Clone, Default)]
pub(crate) struct RelaxedConj {
    pub atoms: Vec<LiftedAtom>,
    pub eqs: Vec<(bool, Arg, Arg)>,
}

/// A flattened effect literal: `forall vars: when condition: (not)? atom`.
#[derive(Debug, Clone)]
pub(crate) struct LiftedEffect {
    pub forall: Vec<Var>,
    pub condition: Formula,
    pub relaxed_condition: Vec<RelaxedConj>,
    pub delete: bool,
    pub atom: LiftedAtom,
}

#[derive(Debug, Clone)]
pub(crate) enum CostTerm {
    /// A number, with where the domain writes it.
    Number(f64, ast::Span),
    /// `(f args)`, with where the domain writes it.
    Function(usize, Vec<Arg>, ast::Span),
}

#[derive(Debug, Clone)]
pub(crate) struct LiftedSchema {
    pub name: String,
    pub param_names: Vec<String>,
    /// Domain (type) of each variable; parameters are variables `0..param_names.len()`.
    pub var_domains: Vec<DomainId>,
    pub pre: Formula,
    pub relaxed_pre: Vec<RelaxedConj>,
    pub effects: Vec<LiftedEffect>,
    pub costs: Vec<CostTerm>,
    /// Where it is written: the action in the domain, or the goal in the problem.
    pub span: ast::Span,
}

impl LiftedSchema {
    pub fn arity(&self) -> usize {
        self.param_names.len()
    }
}

pub(crate) type DomainId = usize;

/// Objects of each type (and of each `either` union), as sorted lists and membership bits.
#[derive(Debug, Default)]
pub(crate) struct TypeDomains {
    pub lists: Vec<Vec<ObjectId>>,
    pub members: Vec<Vec<bool>>,
    by_key: FxHashMap<Vec<String>, DomainId>,
}

impl TypeDomains {
    pub fn contains(&self, domain: DomainId, object: ObjectId) -> bool {
        self.members[domain][object.index()]
    }
}

pub(crate) struct Lifted {
    pub objects: Vec<Object>,
    pub object_ids: FxHashMap<String, ObjectId>,
    pub predicates: Vec<Predicate>,
    pub predicate_ids: FxHashMap<String, PredicateId>,
    pub functions: FxHashMap<String, usize>,
    /// The functions' names, by index.
    pub function_names: Vec<String>,
    pub domains: TypeDomains,
    pub schemas: Vec<LiftedSchema>,
    pub goal: LiftedSchema,
    pub init: Vec<(PredicateId, Vec<ObjectId>)>,
    /// Values of `(= (f o1 ... on) v)` in `:init`: (function, args) → value and where the
    /// problem gives it.
    pub function_values: FxHashMap<(usize, Vec<ObjectId>), (f64, ast::Span)>,
    pub uses_costs: bool,
}

struct Builder<'a> {
    domain: &'a ast::Domain,
    lifted: Lifted,
    /// Type name → parents (a type may have several with `either`).
    parents: FxHashMap<String, Vec<String>>,
}

pub(crate) fn lift(domain: &ast::Domain, problem: &ast::Problem) -> Result<Lifted, GroundingError> {
    let mut builder = Builder {
        domain,
        parents: FxHashMap::default(),
        lifted: Lifted {
            objects: Vec::new(),
            object_ids: FxHashMap::default(),
            predicates: Vec::new(),
            predicate_ids: FxHashMap::default(),
            functions: FxHashMap::default(),
            function_names: Vec::new(),
            domains: TypeDomains::default(),
            schemas: Vec::new(),
            goal: empty_schema("goal"),
            init: Vec::new(),
            function_values: FxHashMap::default(),
            uses_costs: problem.metric.is_some(),
        },
    };
    for declared in &domain.types {
        let parents =
            declared.ty.as_ref().map_or_else(|| vec!["object".to_string()], |ty| ty.names().iter().map(|n| n.text.clone()).collect());
        builder.parents.entry(declared.name.text.clone()).or_default().extend(parents);
    }
    for object in domain.constants.iter().chain(&problem.objects) {
        if builder.lifted.object_ids.contains_key(object.name.as_str()) {
            continue;
        }
        let declared: Vec<String> =
            object.ty.as_ref().map_or_else(|| vec!["object".to_string()], |ty| ty.names().iter().map(|n| n.text.clone()).collect());
        let types = builder.ancestors(&declared);
        let id = ObjectId::from_index(builder.lifted.objects.len());
        builder.lifted.object_ids.insert(object.name.text.clone(), id);
        builder.lifted.objects.push(Object { name: object.name.text.clone(), types });
    }
    for predicate in &domain.predicates {
        let id = PredicateId::from_index(builder.lifted.predicates.len());
        builder.lifted.predicate_ids.insert(predicate.name.text.clone(), id);
        builder.lifted.predicates.push(Predicate { name: predicate.name.text.clone(), arity: predicate.params.len() });
    }
    for (i, function) in domain.functions.iter().enumerate() {
        builder.lifted.functions.insert(function.name.text.clone(), i);
        builder.lifted.function_names.push(function.name.text.clone());
    }
    for element in &problem.init {
        match element {
            ast::InitElement::Atom(atom) => {
                let predicate = builder.predicate(&atom.predicate)?;
                let args = atom.args.iter().map(|t| builder.object(t.name())).collect::<Result<Vec<_>, _>>()?;
                builder.lifted.init.push((predicate, args));
            }
            ast::InitElement::Assign(term, value, span) => {
                let function = builder.function(&term.function)?;
                let args = term.args.iter().map(|t| builder.object(t.name())).collect::<Result<Vec<_>, _>>()?;
                builder.lifted.function_values.insert((function, args), (value.value, *span));
            }
        }
    }
    let mut schemas = Vec::new();
    for action in &domain.actions {
        schemas.push(builder.schema(action)?);
    }
    builder.lifted.schemas = schemas;
    let mut goal = empty_schema("goal");
    if let Some(condition) = &problem.goal {
        goal.span = condition.span();
        let mut scope = Vec::new();
        goal.pre = builder.formula(condition, false, &mut goal.var_domains, &mut scope)?;
        goal.relaxed_pre = relaxed_dnf(&goal.pre);
    }
    builder.lifted.goal = goal;
    Ok(builder.lifted)
}

fn empty_schema(name: &str) -> LiftedSchema {
    LiftedSchema {
        name: name.to_string(),
        param_names: Vec::new(),
        var_domains: Vec::new(),
        pre: Formula::True,
        relaxed_pre: vec![RelaxedConj::default()],
        effects: Vec::new(),
        costs: Vec::new(),
        span: ast::Span::default(),
    }
}

impl Builder<'_> {
    /// The types and all their ancestors, ending with `object`.
    fn ancestors(&self, declared: &[String]) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        let mut stack: Vec<String> = declared.to_vec();
        while let Some(ty) = stack.pop() {
            if out.contains(&ty) {
                continue;
            }
            if let Some(parents) = self.parents.get(&ty) {
                stack.extend(parents.iter().cloned());
            }
            out.push(ty);
        }
        out.retain(|t| t != "object");
        out.push("object".to_string());
        out
    }

    /// The domain of objects of any of `types`.
    fn type_domain(&mut self, ty: Option<&ast::Type>) -> DomainId {
        let mut key: Vec<String> = ty.map_or_else(|| vec!["object".to_string()], |ty| ty.names().iter().map(|n| n.text.clone()).collect());
        key.sort();
        key.dedup();
        let domains = &mut self.lifted.domains;
        if let Some(&id) = domains.by_key.get(&key) {
            return id;
        }
        let members: Vec<bool> = self.lifted.objects.iter().map(|o| key.iter().any(|t| o.types.contains(t))).collect();
        let list = members.iter().enumerate().filter(|(_, m)| **m).map(|(i, _)| ObjectId::from_index(i)).collect();
        let id = domains.lists.len();
        domains.lists.push(list);
        domains.members.push(members);
        domains.by_key.insert(key, id);
        id
    }

    fn predicate(&self, name: &ast::Name) -> Result<PredicateId, GroundingError> {
        self.lifted.predicate_ids.get(name.as_str()).copied().ok_or_else(|| GroundingError::Unresolved(format!("predicate `{name}`")))
    }

    fn function(&self, name: &ast::Name) -> Result<usize, GroundingError> {
        self.lifted.functions.get(name.as_str()).copied().ok_or_else(|| GroundingError::Unresolved(format!("function `{name}`")))
    }

    fn object(&self, name: &ast::Name) -> Result<ObjectId, GroundingError> {
        self.lifted.object_ids.get(name.as_str()).copied().ok_or_else(|| GroundingError::Unresolved(format!("object `{name}`")))
    }

    fn arg(&self, term: &ast::Term, scope: &[(String, Var)]) -> Result<Arg, GroundingError> {
        match term {
            ast::Term::Variable(name) => scope
                .iter()
                .rev()
                .find(|(n, _)| n == name.as_str())
                .map(|&(_, v)| Arg::Var(v))
                .ok_or_else(|| GroundingError::Unresolved(format!("variable `?{name}`"))),
            ast::Term::Constant(name) => self.object(name).map(Arg::Obj),
        }
    }

    fn atom(&self, atom: &ast::Atom, scope: &[(String, Var)]) -> Result<LiftedAtom, GroundingError> {
        let predicate = self.predicate(&atom.predicate)?;
        let args = atom.args.iter().map(|t| self.arg(t, scope)).collect::<Result<Vec<_>, _>>()?;
        Ok(LiftedAtom { predicate, args })
    }

    /// Binds fresh variables for a quantifier or parameter list.
    fn bind(&mut self, variables: &[ast::TypedName], var_domains: &mut Vec<DomainId>, scope: &mut Vec<(String, Var)>) -> Vec<Var> {
        variables
            .iter()
            .map(|v| {
                let var = var_domains.len() as Var;
                var_domains.push(self.type_domain(v.ty.as_ref()));
                scope.push((v.name.text.clone(), var));
                var
            })
            .collect()
    }

    /// `condition` (negated if `negated`) in negation normal form.
    fn formula(
        &mut self,
        condition: &ast::Condition,
        negated: bool,
        var_domains: &mut Vec<DomainId>,
        scope: &mut Vec<(String, Var)>,
    ) -> Result<Formula, GroundingError> {
        Ok(match condition {
            ast::Condition::Atom(atom) => Formula::Atom { negated, atom: self.atom(atom, scope)? },
            ast::Condition::Equals(a, b, _) => Formula::Eq { negated, a: self.arg(a, scope)?, b: self.arg(b, scope)? },
            ast::Condition::Not(inner, _) => self.formula(inner, !negated, var_domains, scope)?,
            ast::Condition::And(parts, _) | ast::Condition::Or(parts, _) => {
                let parts = parts.iter().map(|p| self.formula(p, negated, var_domains, scope)).collect::<Result<Vec<_>, _>>()?;
                let conjunction = matches!(condition, ast::Condition::And(..)) != negated;
                if conjunction { Formula::And(parts) } else { Formula::Or(parts) }
            }
            ast::Condition::Imply(a, b, _) => {
                // a → b  ≡  ¬a ∨ b;   ¬(a → b)  ≡  a ∧ ¬b.
                let a = self.formula(a, !negated, var_domains, scope)?;
                let b = self.formula(b, negated, var_domains, scope)?;
                if negated { Formula::And(vec![a, b]) } else { Formula::Or(vec![a, b]) }
            }
            ast::Condition::Exists(variables, body, _) | ast::Condition::Forall(variables, body, _) => {
                let depth = scope.len();
                let vars = self.bind(variables, var_domains, scope);
                let body = self.formula(body, negated, var_domains, scope)?;
                scope.truncate(depth);
                let existential = matches!(condition, ast::Condition::Exists(..)) != negated;
                if existential {
                    let conjs = relaxed_dnf(&body);
                    Formula::Exists(vars, Box::new(body), conjs)
                } else {
                    Formula::Forall(vars, Box::new(body))
                }
            }
        })
    }

    fn schema(&mut self, action: &ast::Action) -> Result<LiftedSchema, GroundingError> {
        let mut var_domains = Vec::new();
        let mut scope = Vec::new();
        self.bind(&action.params, &mut var_domains, &mut scope);
        let pre = match &action.precondition {
            Some(condition) => self.formula(condition, false, &mut var_domains, &mut scope)?,
            None => Formula::True,
        };
        let mut effects = Vec::new();
        let mut costs = Vec::new();
        if let Some(effect) = &action.effect {
            self.effect(action, effect, &[], &Formula::True, &mut var_domains, &mut scope, &mut effects, &mut costs)?;
        }
        let relaxed_pre = relaxed_dnf(&pre);
        Ok(LiftedSchema {
            name: action.name.text.clone(),
            param_names: action.params.iter().map(|p| p.name.text.clone()).collect(),
            var_domains,
            pre,
            relaxed_pre,
            effects,
            costs,
            span: action.span,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn effect(
        &mut self,
        action: &ast::Action,
        effect: &ast::Effect,
        forall: &[Var],
        condition: &Formula,
        var_domains: &mut Vec<DomainId>,
        scope: &mut Vec<(String, Var)>,
        out: &mut Vec<LiftedEffect>,
        costs: &mut Vec<CostTerm>,
    ) -> Result<(), GroundingError> {
        match effect {
            ast::Effect::And(parts, _) => {
                for part in parts {
                    self.effect(action, part, forall, condition, var_domains, scope, out, costs)?;
                }
            }
            ast::Effect::Add(atom) | ast::Effect::Delete(atom, _) => {
                let atom = self.atom(atom, scope)?;
                out.push(LiftedEffect {
                    forall: forall.to_vec(),
                    relaxed_condition: relaxed_dnf(condition),
                    condition: condition.clone(),
                    delete: matches!(effect, ast::Effect::Delete(..)),
                    atom,
                });
            }
            ast::Effect::Forall(variables, body, _) => {
                let depth = scope.len();
                let mut vars = forall.to_vec();
                vars.extend(self.bind(variables, var_domains, scope));
                self.effect(action, body, &vars, condition, var_domains, scope, out, costs)?;
                scope.truncate(depth);
            }
            ast::Effect::When(when, body, _) => {
                let when = self.formula(when, false, var_domains, scope)?;
                let combined = match condition {
                    Formula::True => when,
                    other => Formula::And(vec![other.clone(), when]),
                };
                self.effect(action, body, forall, &combined, var_domains, scope, out, costs)?;
            }
            ast::Effect::Increase(function, value, span) => {
                if function.function.as_str() != "total-cost" {
                    return Err(GroundingError::Unsupported {
                        message: format!("action `{}` increases `{}`; only `total-cost` can be increased", action.name, function.function),
                        span: *span,
                    });
                }
                if !forall.is_empty() || !matches!(condition, Formula::True) {
                    return Err(GroundingError::Unsupported {
                        message: format!(
                            "action `{}` increases `total-cost` under `forall` or `when`; costs must be unconditional",
                            action.name
                        ),
                        span: *span,
                    });
                }
                costs.push(match value {
                    ast::NumericExpr::Number(number) => CostTerm::Number(number.value, number.span),
                    ast::NumericExpr::Function(term) => {
                        let function = self.function(&term.function)?;
                        let args = term.args.iter().map(|t| self.arg(t, scope)).collect::<Result<Vec<_>, _>>()?;
                        CostTerm::Function(function, args, term.span)
                    }
                });
            }
        }
        let _ = self.domain;
        Ok(())
    }
}

/// Conjunctions cap for the relaxed DNF; past it the relaxation gives up precision (returns
/// "always satisfiable"), which only makes reachability over-approximate.
const RELAXED_DNF_CAP: usize = 256;

/// The delete relaxation of a formula as a disjunction of conjunctions of positive atoms
/// and (in)equalities. Negative literals and universally quantified parts are dropped
/// (treated as satisfiable); existential variables stay free and are bound by the join.
pub(crate) fn relaxed_dnf(formula: &Formula) -> Vec<RelaxedConj> {
    match formula {
        Formula::True | Formula::Atom { negated: true, .. } | Formula::Forall(..) => vec![RelaxedConj::default()],
        Formula::Atom { negated: false, atom } => vec![RelaxedConj { atoms: vec![atom.clone()], eqs: Vec::new() }],
        Formula::Eq { negated, a, b } => vec![RelaxedConj { atoms: Vec::new(), eqs: vec![(*negated, *a, *b)] }],
        Formula::Exists(_, body, _) => relaxed_dnf(body),
        Formula::Or(parts) => {
            let mut out = Vec::new();
            for part in parts {
                out.extend(relaxed_dnf(part));
                if out.iter().any(|c: &RelaxedConj| c.atoms.is_empty() && c.eqs.is_empty()) {
                    return vec![RelaxedConj::default()];
                }
            }
            out
        }
        Formula::And(parts) => {
            let mut acc = vec![RelaxedConj::default()];
            for part in parts {
                let alternatives = relaxed_dnf(part);
                if alternatives.len() == 1 {
                    for conj in &mut acc {
                        conj.atoms.extend(alternatives[0].atoms.iter().cloned());
                        conj.eqs.extend(alternatives[0].eqs.iter().copied());
                    }
                    continue;
                }
                if alternatives.iter().any(|c| c.atoms.is_empty() && c.eqs.is_empty()) {
                    continue; // part is relaxed-true
                }
                if acc.len() * alternatives.len() > RELAXED_DNF_CAP {
                    continue; // over-approximate: drop this part
                }
                let mut next = Vec::with_capacity(acc.len() * alternatives.len());
                for conj in &acc {
                    for alternative in &alternatives {
                        let mut merged = conj.clone();
                        merged.atoms.extend(alternative.atoms.iter().cloned());
                        merged.eqs.extend(alternative.eqs.iter().copied());
                        next.push(merged);
                    }
                }
                acc = next;
            }
            acc
        }
    }
}
