//! The grounded task: interned facts and actions, conditions, effects and the goal.

use smallvec::SmallVec;

use crate::ids::{ActionId, FactId, ObjectId, PredicateId, SchemaId};

/// A fact or its negation: `fact << 1 | negated`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Literal(u32);

impl Literal {
    /// The literal that holds when `fact` is true.
    pub fn positive(fact: FactId) -> Literal {
        Literal(fact.0 << 1)
    }

    /// The literal that holds when `fact` is false.
    pub fn negative(fact: FactId) -> Literal {
        Literal(fact.0 << 1 | 1)
    }

    /// The negative literal of `fact` when `negated`, else the positive one.
    pub fn new(fact: FactId, negated: bool) -> Literal {
        Literal(fact.0 << 1 | negated as u32)
    }

    /// The fact, whatever the sign.
    pub fn fact(self) -> FactId {
        FactId(self.0 >> 1)
    }

    /// Whether this is the literal "`fact` is false".
    pub fn is_negated(self) -> bool {
        self.0 & 1 == 1
    }

    /// The complementary literal: same fact, other sign.
    pub fn negate(self) -> Literal {
        Literal(self.0 ^ 1)
    }
}

/// A conjunction of literals plus a conjunction of clauses (disjunctions of literals), over
/// fluent facts. This is what any grounded formula becomes after its top-level disjunctions
/// have been split off into separate actions or goal disjuncts (see the crate docs): a
/// disjunction of literals that sits under a conjunction, such as the expansion of
/// `(not (exists (?o) (and (in ?x ?o) (closed ?o))))`, stays a clause instead of multiplying
/// the action.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct Condition {
    /// Facts that must hold, sorted, without duplicates.
    pub pos: Vec<FactId>,
    /// Facts that must not hold, sorted, without duplicates.
    pub neg: Vec<FactId>,
    /// Each clause needs one of its literals to hold. Every clause has at least two literals.
    pub clauses: Vec<Vec<Literal>>,
}

impl Condition {
    /// Whether there are no literals and no clauses, so the condition always holds.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty() && self.neg.is_empty() && self.clauses.is_empty()
    }

    /// Evaluates the condition given a membership test for facts.
    #[inline]
    pub fn holds(&self, is_true: impl Fn(FactId) -> bool) -> bool {
        self.pos.iter().all(|&f| is_true(f))
            && self.neg.iter().all(|&f| !is_true(f))
            && self.clauses.iter().all(|clause| clause.iter().any(|l| is_true(l.fact()) != l.is_negated()))
    }

    /// The literals of `pos` and `neg`, positive first.
    pub fn literals(&self) -> impl Iterator<Item = Literal> + '_ {
        self.pos.iter().map(|&f| Literal::positive(f)).chain(self.neg.iter().map(|&f| Literal::negative(f)))
    }
}

/// A conditional effect: when `condition` holds in the state the action is applied in,
/// `del` is removed and then `add` is added.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct ConditionalEffect {
    /// Must hold, in the state the action is applied in, for the effect to fire; never empty in a
    /// [`Task`] (such effects are merged into [`Action::add`] and [`Action::del`]).
    pub condition: Condition,
    /// Facts added when the effect fires, sorted, without duplicates.
    pub add: Vec<FactId>,
    /// Facts deleted when the effect fires, sorted, without duplicates.
    pub del: Vec<FactId>,
}

/// Action costs are non-negative integers, as in Fast Downward.
pub type Cost = u32;

/// A grounded action.
///
/// Applying it in state `s`: every conditional effect whose condition holds in `s` fires;
/// all deletes (unconditional and fired) are removed first, then all adds are added, so an
/// action that both adds and deletes a fact leaves it true (PDDL semantics).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Action {
    /// The schema it instantiates: an index into [`Task::schemas`].
    pub schema: SchemaId,
    /// Values of the schema's parameters, in order. Actions split from one disjunctive or
    /// existential precondition share their schema and arguments, so they share a name.
    pub args: SmallVec<[ObjectId; 6]>,
    /// Must hold for the action to be applicable; over fluent facts only (static ones were
    /// evaluated away).
    pub pre: Condition,
    /// Unconditional adds and deletes, sorted, without duplicates.
    pub add: Vec<FactId>,
    /// Unconditional deletes, sorted, without duplicates; none is also in `add` (adds win) or in
    /// `pre.neg` (already false).
    pub del: Vec<FactId>,
    /// Effects that fire only where their condition holds.
    pub conditional: Vec<ConditionalEffect>,
    /// The sum of the schema's `(increase (total-cost) ...)` terms when the problem has a `:metric`
    /// (0 without such terms); 1 when it has none.
    pub cost: Cost,
}

/// A ground atom: predicate and arguments.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Atom {
    /// An index into [`Task::predicates`].
    pub predicate: PredicateId,
    /// Indexes into [`Task::objects`], in order, as many as the predicate's arity.
    pub args: SmallVec<[ObjectId; 4]>,
}

/// What an action schema looks like after grounding, for naming and spelling actions.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schema {
    /// The action's name as the domain writes it, lowercased.
    pub name: String,
    /// Parameter names without `?`, lowercased.
    pub params: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Eq)]
/// A predicate the domain declares, indexed by [`PredicateId`].
pub struct Predicate {
    /// Its name, lowercased.
    pub name: String,
    /// Its number of arguments.
    pub arity: usize,
}

#[derive(Debug, Clone, PartialEq, Eq)]
/// An object or constant, indexed by [`ObjectId`]: the domain's `:constants` first, then the
/// problem's `:objects`, each in the order declared.
pub struct Object {
    /// Its name, lowercased.
    pub name: String,
    /// The declared type and all its ancestors, ending with `object`.
    pub types: Vec<String>,
}

/// The goal: a disjunction of [`Condition`]s. A conjunctive goal is one disjunct; an
/// ALFWorld goal `(exists (?o ?r) (and ...))` becomes one disjunct per binding of the
/// quantified variables that could hold in some reachable state (static facts decide the
/// rest at grounding time). No disjunct means the goal can never hold; an empty disjunct
/// means it always holds.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Goal {
    /// The alternatives: the goal holds in a state where one of them does.
    pub disjuncts: Vec<Condition>,
}

impl Goal {
    /// Whether some disjunct holds, given a membership test for fluent facts.
    pub fn holds(&self, is_true: impl Fn(FactId) -> bool + Copy) -> bool {
        self.disjuncts.iter().any(|d| d.holds(is_true))
    }
}

/// A grounded planning task.
///
/// Only *fluent* facts (ones some reachable action adds or deletes) get a [`FactId`]; facts
/// that never change were evaluated away and are listed in [`Task::static_facts`].
#[derive(Debug, Clone)]
pub struct Task {
    /// The name after `(domain ...)`, lowercased.
    pub domain_name: String,
    /// The name after `(problem ...)`, lowercased.
    pub problem_name: String,
    /// Every object and constant, indexed by [`ObjectId`].
    pub objects: Vec<Object>,
    /// Every predicate the domain declares (static ones too), indexed by [`PredicateId`].
    pub predicates: Vec<Predicate>,
    /// Every action schema of the domain, indexed by [`SchemaId`], in the order declared, even those
    /// with no reachable action.
    pub schemas: Vec<Schema>,
    /// Fluent facts, indexed by [`FactId`].
    pub facts: Vec<Atom>,
    /// Actions, indexed by [`ActionId`], sorted by schema then arguments.
    pub actions: Vec<Action>,
    /// Fluent facts true in the initial state, sorted.
    pub init: Vec<FactId>,
    /// The goal, over fluent facts.
    pub goal: Goal,
    /// Facts true in every reachable state (never deleted), for display: prompts show them.
    pub static_facts: Vec<Atom>,
    /// Whether the problem has a `:metric`; without one every action costs 1 (as in Fast Downward).
    pub uses_costs: bool,
}

impl Task {
    /// The atom a fact id stands for; panics when `fact` is not an id of this task.
    pub fn fact(&self, fact: FactId) -> &Atom {
        &self.facts[fact.index()]
    }

    /// The action an id stands for; panics when `action` is not an id of this task.
    pub fn action(&self, action: ActionId) -> &Action {
        &self.actions[action.index()]
    }

    /// Every fact id, in increasing order.
    pub fn fact_ids(&self) -> impl Iterator<Item = FactId> + use<> {
        (0..self.facts.len() as u32).map(FactId)
    }

    /// Every action id, in increasing order.
    pub fn action_ids(&self) -> impl Iterator<Item = ActionId> + use<> {
        (0..self.actions.len() as u32).map(ActionId)
    }

    /// Whether every action costs 1, so that a plan's cost is its length (a bound on cost is
    /// then a bound on the number of steps).
    pub fn has_unit_costs(&self) -> bool {
        self.actions.iter().all(|a| a.cost == 1)
    }

    /// Whether some action has a conditional effect (where LM-cut charged apart may
    /// overestimate: `heuristics::LmCut`).
    pub fn has_conditional_effects(&self) -> bool {
        self.actions.iter().any(|a| !a.conditional.is_empty())
    }

    /// `(pred a b)`.
    pub fn atom_name(&self, atom: &Atom) -> String {
        let mut out = format!("({}", self.predicates[atom.predicate.index()].name);
        for arg in &atom.args {
            out.push(' ');
            out.push_str(&self.objects[arg.index()].name);
        }
        out.push(')');
        out
    }

    /// The fact as `(pred a b)`; panics when `fact` is not an id of this task.
    pub fn fact_name(&self, fact: FactId) -> String {
        self.atom_name(self.fact(fact))
    }

    /// `(pred a b)`, or `(not (pred a b))` for a negative literal.
    pub fn literal_name(&self, literal: Literal) -> String {
        let name = self.fact_name(literal.fact());
        if literal.is_negated() { format!("(not {name})") } else { name }
    }

    /// `(schema a b)`, as Fast Downward names operators.
    pub fn action_name(&self, action: ActionId) -> String {
        let action = self.action(action);
        let mut out = format!("({}", self.schemas[action.schema.index()].name);
        for arg in &action.args {
            out.push(' ');
            out.push_str(&self.objects[arg.index()].name);
        }
        out.push(')');
        out
    }

    /// The object with this name, compared after lowercasing `name` (stored names are lowercase);
    /// `None` when there is none.
    pub fn object_by_name(&self, name: &str) -> Option<ObjectId> {
        let lower = name.to_lowercase();
        self.objects.iter().position(|o| o.name == lower).map(|i| ObjectId(i as u32))
    }
}
