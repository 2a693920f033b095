//! Reachable ground atoms, indexed for joins, and the join itself: all bindings of a
//! conjunction's variables under which each of its atoms is in the store.
//!
//! This is the relational core of grounding (Fast Downward's translator does the same with
//! a Datalog program): actions are grounded by joining their preconditions against what is
//! reachable, never by enumerating all argument tuples. Written by hand: the join needs
//! typed variables, partial bindings and per-position indexes that no Datalog crate offers.

use rustc_hash::{FxHashMap, FxHashSet};
use smallvec::SmallVec;

use crate::ids::{ObjectId, PredicateId};
use crate::lifted::{Arg, DomainId, LiftedAtom, RelaxedConj, TypeDomains, Var};

pub(crate) type Tuple = SmallVec<[ObjectId; 4]>;

#[derive(Debug, Default)]
struct Relation {
    tuples: Vec<Tuple>,
    set: FxHashSet<Tuple>,
    /// (argument position, object) → indices into `tuples`.
    index: FxHashMap<(u32, ObjectId), Vec<u32>>,
}

/// A growing set of ground atoms, by predicate.
#[derive(Debug)]
pub(crate) struct AtomStore {
    relations: Vec<Relation>,
}

impl AtomStore {
    pub fn new(predicates: usize) -> AtomStore {
        AtomStore { relations: (0..predicates).map(|_| Relation::default()).collect() }
    }

    /// Adds an atom; false if it was already there.
    pub fn insert(&mut self, predicate: PredicateId, args: &[ObjectId]) -> bool {
        let relation = &mut self.relations[predicate.index()];
        if relation.set.contains(args) {
            return false;
        }
        let tuple: Tuple = args.iter().copied().collect();
        let at = relation.tuples.len() as u32;
        for (position, &object) in args.iter().enumerate() {
            relation.index.entry((position as u32, object)).or_default().push(at);
        }
        relation.set.insert(tuple.clone());
        relation.tuples.push(tuple);
        true
    }

    pub fn contains(&self, predicate: PredicateId, args: &[ObjectId]) -> bool {
        self.relations[predicate.index()].set.contains(args)
    }

    pub fn tuples(&self, predicate: PredicateId) -> &[Tuple] {
        &self.relations[predicate.index()].tuples
    }
}

/// Variable bindings during a join; `None` is unbound.
pub(crate) type Binding = Vec<Option<ObjectId>>;

fn resolve(arg: Arg, binding: &Binding) -> Option<ObjectId> {
    match arg {
        Arg::Obj(object) => Some(object),
        Arg::Var(var) => binding[var as usize],
    }
}

pub(crate) struct Join<'a> {
    pub store: &'a AtomStore,
    pub domains: &'a TypeDomains,
    pub var_domains: &'a [DomainId],
    /// Set (by the caller's `emit`) to end the join early: every loop checks it.
    pub stop: Option<&'a std::cell::Cell<bool>>,
}

impl Join<'_> {
    fn stopped(&self) -> bool {
        self.stop.is_some_and(std::cell::Cell::get)
    }

    /// Calls `emit` with every extension of `binding` that satisfies `conj` (atoms in the
    /// store, equalities, variable types) and binds every variable in `must_bind`
    /// (unconstrained ones range over their type). Other variables may stay unbound.
    pub fn run(&self, conj: &RelaxedConj, binding: &mut Binding, must_bind: &[Var], emit: &mut dyn FnMut(&Binding)) {
        let mut done = vec![false; conj.atoms.len()];
        self.atoms(conj, &mut done, binding, must_bind, emit);
    }

    fn atoms(&self, conj: &RelaxedConj, done: &mut [bool], binding: &mut Binding, must_bind: &[Var], emit: &mut dyn FnMut(&Binding)) {
        // Most-bound atom first; ties go to the smaller relation.
        let mut best: Option<(usize, usize, usize)> = None; // (atom, bound args, size)
        for (i, atom) in conj.atoms.iter().enumerate() {
            if done[i] {
                continue;
            }
            let bound = atom.args.iter().filter(|a| resolve(**a, binding).is_some()).count();
            let size = self.store.tuples(atom.predicate).len();
            let better = match best {
                None => true,
                Some((_, b, s)) => bound > b || (bound == b && size < s),
            };
            if better {
                best = Some((i, bound, size));
            }
        }
        let Some((i, _, _)) = best else {
            self.finish(conj, binding, must_bind, 0, emit);
            return;
        };
        done[i] = true;
        let atom = &conj.atoms[i];
        self.match_atom(atom, binding, &mut |binding| self.atoms(conj, done, binding, must_bind, emit));
        done[i] = false;
    }

    /// Binds `atom`'s free variables to every matching tuple in turn.
    fn match_atom(&self, atom: &LiftedAtom, binding: &mut Binding, next: &mut dyn FnMut(&mut Binding)) {
        let relation = &self.store.relations[atom.predicate.index()];
        let resolved: SmallVec<[Option<ObjectId>; 4]> = atom.args.iter().map(|a| resolve(*a, binding)).collect();
        if resolved.iter().all(Option::is_some) {
            let tuple: Tuple = resolved.iter().map(|o| o.unwrap_or_default()).collect();
            if relation.set.contains(&tuple) {
                next(binding);
            }
            return;
        }
        // Candidate tuples: the shortest index list among bound positions, else all.
        let mut candidates: Option<&[u32]> = None;
        for (position, object) in resolved.iter().enumerate() {
            if let Some(object) = object {
                let list = relation.index.get(&(position as u32, *object)).map_or(&[][..], Vec::as_slice);
                if candidates.is_none_or(|c| list.len() < c.len()) {
                    candidates = Some(list);
                }
            }
        }
        let mut try_tuple = |tuple: &Tuple, binding: &mut Binding| {
            let mut newly_bound: SmallVec<[Var; 4]> = SmallVec::new();
            let mut ok = true;
            for (arg, &object) in atom.args.iter().zip(tuple.iter()) {
                match *arg {
                    Arg::Obj(expected) => ok = expected == object,
                    Arg::Var(var) => match binding[var as usize] {
                        Some(bound) => ok = bound == object,
                        None => {
                            if self.domains.contains(self.var_domains[var as usize], object) {
                                binding[var as usize] = Some(object);
                                newly_bound.push(var);
                            } else {
                                ok = false;
                            }
                        }
                    },
                }
                if !ok {
                    break;
                }
            }
            if ok {
                next(binding);
            }
            for var in newly_bound {
                binding[var as usize] = None;
            }
        };
        match candidates {
            Some(list) => {
                for &index in list {
                    if self.stopped() {
                        return;
                    }
                    try_tuple(&relation.tuples[index as usize], binding);
                }
            }
            None => {
                for tuple in &relation.tuples {
                    if self.stopped() {
                        return;
                    }
                    try_tuple(tuple, binding);
                }
            }
        }
    }

    /// After all atoms: bind the remaining `must_bind` variables over their types, then
    /// check the (in)equalities.
    fn finish(&self, conj: &RelaxedConj, binding: &mut Binding, must_bind: &[Var], from: usize, emit: &mut dyn FnMut(&Binding)) {
        if let Some(offset) = must_bind[from..].iter().position(|&v| binding[v as usize].is_none()) {
            let position = from + offset;
            let var = must_bind[position];
            for &object in &self.domains.lists[self.var_domains[var as usize]] {
                if self.stopped() {
                    break;
                }
                binding[var as usize] = Some(object);
                if self.equalities_possible(conj, binding) {
                    self.finish(conj, binding, must_bind, position + 1, emit);
                }
            }
            binding[var as usize] = None;
            return;
        }
        // Variables bound by the caller were not type-checked by the join.
        if !must_bind.iter().all(|&v| binding[v as usize].is_some_and(|o| self.domains.contains(self.var_domains[v as usize], o))) {
            return;
        }
        let equalities_hold = conj.eqs.iter().all(|&(negated, a, b)| match (resolve(a, binding), resolve(b, binding)) {
            (Some(a), Some(b)) => (a == b) != negated,
            _ => true, // an unbound side is an existential variable: some value may satisfy it
        });
        if equalities_hold {
            emit(binding);
        }
    }

    fn equalities_possible(&self, conj: &RelaxedConj, binding: &Binding) -> bool {
        conj.eqs.iter().all(|&(negated, a, b)| match (resolve(a, binding), resolve(b, binding)) {
            (Some(a), Some(b)) => (a == b) != negated,
            _ => true,
        })
    }
}
