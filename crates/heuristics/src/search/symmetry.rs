//! Interchangeable objects, and A* over states up to a permutation of them (orbit search).
//!
//! Two objects are interchangeable when swapping them maps the grounded task onto itself:
//! every fact and action onto a fact and an action, each action's precondition, effects and
//! cost onto its image's, the initial state and the goal onto themselves. Such swaps generate
//! a group of permutations, one symmetric group per class of interchangeable objects (five
//! plates EAI's task asks to put in the dishwasher, gripper's balls), and every permutation in
//! it maps plans onto plans of the same cost and goal states onto goal states.
//!
//! A search that registers each state as a permuted image of itself ([`ObjectSymmetries::canonical_permutation`])
//! keeps one of the many states that differ only in which plate went in first: A* stays
//! optimal (each stored state is a real state reached at the same cost, and the goal is
//! invariant), and the plan found in the permuted space is mapped back to the task's own
//! objects step by step ([`ObjectSymmetries::unpermute_plan`]). The image chosen sorts each
//! class's objects by the facts of the state that mention them, so states that differ by a
//! permutation of objects whose facts name no other object of their class meet in one image;
//! where they do (a plate on a plate), the image is still a symmetric state, only not always
//! the same one (the search is then correct and merges less).
//!
//! This is the object-level case of the structural symmetries of Domshlak, Katz and
//! Shleyfman (ICAPS 2012; Fast Downward's `symmetries` option, which the release we compare
//! with does not ship). It is written here because no Rust planning library provides it; it
//! needs only the grounded task, so it works with any heuristic and with conditional effects
//! and disjunctive conditions, which a graph-automorphism tool on Fast Downward's SAS+ output
//! would not see.

use hashbrown::{HashMap, HashSet};
use smallvec::SmallVec;

use grounding::{ActionId, Atom, Condition, FactId, ObjectId, Task};
use transition_model::State;

/// Classes of interchangeable objects of one task, and what canonicalizing a state needs.
#[derive(Debug, Clone, Default)]
pub struct ObjectSymmetries {
    /// Each class sorted by id, at least two objects.
    classes: Vec<Vec<ObjectId>>,
    /// For each member (the classes' objects in order), its facts as (fact, key), by key: the
    /// key names the fact with the member itself and every other member replaced by a marker.
    member_facts: Vec<Vec<(FactId, u32)>>,
    /// Facts that mention a member (only these move under a permutation).
    moving: Vec<FactId>,
    fact_index: HashMap<Atom, FactId>,
    /// The task's facts, by id (for their images).
    atoms: Vec<Atom>,
    /// Actions by name: grounding may split one (an `or` in a precondition) into several.
    action_index: HashMap<ActionName, SmallVec<[ActionId; 2]>>,
    objects: usize,
    /// Scratch: the profiles' keys, flat, their ranges per member, and the order.
    keys: Vec<u32>,
    ranges: Vec<(u32, u32)>,
    order: Vec<u32>,
}

/// An action's schema and arguments.
type ActionName = (u32, SmallVec<[ObjectId; 6]>);

/// Where an object occurs: (init, goal, negated goal or action; predicate or schema; position).
type Signature = Vec<(u8, u32, u32)>;

/// A permutation of the task's objects: `perm[o]` is o's image.
pub type Permutation = Vec<ObjectId>;

impl ObjectSymmetries {
    /// The classes of interchangeable objects of `task` (none when there are none).
    ///
    /// Each candidate swap is checked as [`ObjectSymmetries::detect_by_definition`] does, with
    /// the same result, but only against the actions that mention one of the two objects (an
    /// index built once); an action whose name the swap keeps is compared with its image on the
    /// parts that mention them only, the others through canonical encodings made in reused
    /// buffers, and an action found as another's image is not checked again (a swap is its own
    /// inverse). On EAI's hand-over of task 580_1 (209,055 actions; a walk action carries a
    /// conditional effect per object and pair of objects) a swap of two hangers moves about
    /// 20,000 actions; `cargo bench -p heuristics -- symmetry-detect` compares the two.
    pub fn detect(task: &Task) -> ObjectSymmetries {
        let mut out = ObjectSymmetries::indexed(task);
        let groups = candidate_groups(task);
        if !groups.is_empty() {
            let mut checker = Checker::new(task, &out.fact_index, &out.action_index, &groups);
            out.classes = classes_by_swaps(&groups, |a, b| checker.swap_is_automorphism(a, b));
        }
        out.index_members(task);
        out
    }

    /// The classes of [`ObjectSymmetries::detect`], found by the definition: every candidate
    /// swap checked against every action, each compared whole with its image. Slow on large
    /// tasks; kept as the reference `detect` is tested and measured against.
    #[doc(hidden)]
    pub fn detect_by_definition(task: &Task) -> ObjectSymmetries {
        let mut out = ObjectSymmetries::indexed(task);
        let groups = candidate_groups(task);
        let init: HashSet<FactId> = task.init.iter().copied().collect();
        let goal: HashSet<NormCondition> = task.goal.disjuncts.iter().map(|d| NormCondition::of(d, &|f| f)).collect();
        let actions: Vec<NormAction> =
            if groups.is_empty() { Vec::new() } else { task.actions.iter().map(|a| NormAction::of(a, &|f| f)).collect() };
        out.classes = classes_by_swaps(&groups, |a, b| out.swap_is_automorphism(task, &init, &goal, &actions, a, b));
        out.index_members(task);
        out
    }

    /// No classes yet; the indexes every detection needs.
    fn indexed(task: &Task) -> ObjectSymmetries {
        let mut out = ObjectSymmetries { objects: task.objects.len(), ..ObjectSymmetries::default() };
        out.atoms = task.facts.clone();
        out.fact_index = task.facts.iter().enumerate().map(|(i, a)| (a.clone(), FactId(i as u32))).collect();
        for (i, a) in task.actions.iter().enumerate() {
            out.action_index.entry((a.schema.0, a.args.clone())).or_default().push(ActionId(i as u32));
        }
        out
    }

    /// The classes of interchangeable objects, each sorted, at least two objects each.
    pub fn classes(&self) -> &[Vec<ObjectId>] {
        &self.classes
    }

    /// Whether there is nothing to permute.
    pub fn is_trivial(&self) -> bool {
        self.classes.is_empty()
    }

    /// Whether swapping `a` and `b` maps the task onto itself (`actions`: each action's own
    /// [`NormAction`]).
    fn swap_is_automorphism(
        &self,
        task: &Task,
        init: &HashSet<FactId>,
        goal: &HashSet<NormCondition>,
        actions: &[NormAction],
        a: ObjectId,
        b: ObjectId,
    ) -> bool {
        let swap = |o: ObjectId| {
            if o == a {
                b
            } else if o == b {
                a
            } else {
                o
            }
        };
        let mut fact_image: Vec<FactId> = Vec::with_capacity(task.facts.len());
        for (i, atom) in task.facts.iter().enumerate() {
            if !atom.args.iter().any(|&o| o == a || o == b) {
                fact_image.push(FactId(i as u32));
                continue;
            }
            let image = Atom { predicate: atom.predicate, args: atom.args.iter().map(|&o| swap(o)).collect() };
            match self.fact_index.get(&image) {
                Some(&f) => fact_image.push(f),
                None => return false,
            }
        }
        let map = |f: FactId| fact_image[f.index()];
        if task.init.iter().any(|&f| !init.contains(&map(f))) {
            return false;
        }
        if task.goal.disjuncts.iter().any(|d| !goal.contains(&NormCondition::of(d, &map))) {
            return false;
        }
        task.actions.iter().all(|action| {
            let moves_fact = |fs: &[FactId]| fs.iter().any(|&f| map(f) != f);
            let moves = action.args.iter().any(|&o| o == a || o == b)
                || condition_facts(&action.pre).any(|f| map(f) != f)
                || moves_fact(&action.add)
                || moves_fact(&action.del)
                || action
                    .conditional
                    .iter()
                    .any(|c| condition_facts(&c.condition).any(|f| map(f) != f) || moves_fact(&c.add) || moves_fact(&c.del));
            if !moves {
                return true;
            }
            let args: SmallVec<[ObjectId; 6]> = action.args.iter().map(|&o| swap(o)).collect();
            let Some(candidates) = self.action_index.get(&(action.schema.0, args)) else { return false };
            let mapped = NormAction::of(action, &map);
            candidates.iter().any(|&c| task.action(c).cost == action.cost && actions[c.index()] == mapped)
        })
    }

    fn index_members(&mut self, task: &Task) {
        let mut class_of: Vec<Option<u32>> = vec![None; task.objects.len()];
        let mut member_of: Vec<Option<usize>> = vec![None; task.objects.len()];
        let mut m = 0;
        for (c, class) in self.classes.iter().enumerate() {
            for &o in class {
                class_of[o.index()] = Some(c as u32);
                member_of[o.index()] = Some(m);
                m += 1;
            }
        }
        self.member_facts = vec![Vec::new(); m];
        let mut keys: HashMap<(u32, Vec<u64>), u32> = HashMap::new();
        for (i, atom) in task.facts.iter().enumerate() {
            if !atom.args.iter().any(|o| member_of[o.index()].is_some()) {
                continue;
            }
            self.moving.push(FactId(i as u32));
            for (pos, o) in atom.args.iter().enumerate() {
                let Some(member) = member_of[o.index()] else { continue };
                // The fact as seen from this member: itself, other members by class, the rest as is.
                let shape: Vec<u64> = atom
                    .args
                    .iter()
                    .enumerate()
                    .map(|(p, x)| match class_of[x.index()] {
                        _ if p == pos => u64::MAX,
                        Some(c) => (1 << 40) | u64::from(c),
                        None => u64::from(x.0),
                    })
                    .collect();
                let next = keys.len() as u32;
                let key = *keys.entry((atom.predicate.0, shape)).or_insert(next);
                self.member_facts[member].push((FactId(i as u32), key));
            }
        }
        // Keys in the order of the first class's facts are arbitrary but fixed; sort each
        // member's list by key so that a profile comes out sorted.
        for list in &mut self.member_facts {
            list.sort_unstable_by_key(|&(f, k)| (k, f.0));
        }
    }

    /// The permutation that takes `state` to the image the search registers, and whether it
    /// moves anything. Allocates nothing once its scratch has grown.
    pub fn canonical_permutation(&mut self, state: &State, perm: &mut Permutation) -> bool {
        perm.clear();
        perm.extend((0..self.objects as u32).map(ObjectId));
        let mut moved = false;
        let mut member = 0;
        for class in &self.classes {
            self.keys.clear();
            self.ranges.clear();
            for m in member..member + class.len() {
                let start = self.keys.len() as u32;
                self.keys.extend(self.member_facts[m].iter().filter(|&&(f, _)| state.contains(f)).map(|&(_, k)| k));
                self.ranges.push((start, self.keys.len() as u32));
            }
            self.order.clear();
            self.order.extend(0..class.len() as u32);
            let (keys, ranges) = (&self.keys, &self.ranges);
            let profile = |i: u32| {
                let (s, e) = ranges[i as usize];
                &keys[s as usize..e as usize]
            };
            self.order.sort_by(|&x, &y| profile(x).cmp(profile(y)).then(x.cmp(&y)));
            for (rank, &i) in self.order.iter().enumerate() {
                perm[class[i as usize].index()] = class[rank];
                moved |= i as usize != rank;
            }
            member += class.len();
        }
        moved
    }

    /// `state` under `perm` (a permutation of the classes' objects), into `out`.
    pub fn permute_state(&self, state: &State, perm: &Permutation, out: &mut State) {
        out.clone_from(state);
        for &f in &self.moving {
            out.remove(f);
        }
        for &f in &self.moving {
            if state.contains(f) {
                out.insert(self.fact_image(f, perm));
            }
        }
    }

    fn fact_image(&self, f: FactId, perm: &Permutation) -> FactId {
        let atom = &self.atoms[f.index()];
        if atom.args.iter().all(|o| perm[o.index()] == *o) {
            return f;
        }
        let image = Atom { predicate: atom.predicate, args: atom.args.iter().map(|o| perm[o.index()]).collect() };
        // Every fact has an image: the classes were admitted only so.
        self.fact_index[&image]
    }

    /// `action` under `perm`: the action of the image's name whose precondition and effects
    /// are the images of `action`'s.
    pub fn action_image(&self, task: &Task, action: ActionId, perm: &Permutation) -> ActionId {
        let a = task.action(action);
        let mapped = NormAction::of(a, &|f| self.fact_image(f, perm));
        if a.args.iter().all(|o| perm[o.index()] == *o) && mapped == NormAction::of(a, &|f| f) {
            return action;
        }
        let args: SmallVec<[ObjectId; 6]> = a.args.iter().map(|o| perm[o.index()]).collect();
        // Every action has an image: the classes were admitted only so.
        *self.action_index[&(a.schema.0, args)]
            .iter()
            .find(|&&c| task.action(c).cost == a.cost && NormAction::of(task.action(c), &|f| f) == mapped)
            .expect("an automorphism maps every action onto an action")
    }

    /// A plan found over registered images, as the task's own actions: `steps` holds each
    /// step's action (as applied to the registered state before it) and the permutation that
    /// made the registered state after it from that action's successor, in order.
    pub fn unpermute_plan(&self, task: &Task, steps: &[(ActionId, Permutation)]) -> Vec<ActionId> {
        // The real state is π(image); π starts as the identity and after a step whose successor
        // σ made the image, π becomes π ∘ σ⁻¹.
        let mut pi: Permutation = (0..self.objects as u32).map(ObjectId).collect();
        let mut inverse: Permutation = pi.clone();
        let mut plan = Vec::with_capacity(steps.len());
        for (action, sigma) in steps {
            plan.push(self.action_image(task, *action, &pi));
            for (o, &image) in sigma.iter().enumerate() {
                inverse[image.index()] = ObjectId(o as u32);
            }
            pi = inverse.iter().map(|&o| pi[o.index()]).collect();
        }
        plan
    }
}

/// The classes of interchangeable objects within each group, given which swaps map the task
/// onto itself: such swaps make an equivalence relation (two of them compose to a third), so
/// each object is checked against one member of each class so far. Sorted, each at least two.
fn classes_by_swaps(groups: &[Vec<ObjectId>], mut is_automorphism: impl FnMut(ObjectId, ObjectId) -> bool) -> Vec<Vec<ObjectId>> {
    let mut out = Vec::new();
    for group in groups {
        let mut classes: Vec<Vec<ObjectId>> = Vec::new();
        for &o in group {
            match classes.iter_mut().find(|c| is_automorphism(c[0], o)) {
                Some(class) => class.push(o),
                None => classes.push(vec![o]),
            }
        }
        out.extend(classes.into_iter().filter(|c| c.len() > 1));
    }
    out.sort();
    out
}

/// Objects that may be interchangeable, in groups: those of the same types whose occurrences
/// in the initial state, the goal and the actions' arguments look alike (by predicate or
/// schema and position), each group sorted, at least two objects each, the groups sorted.
fn candidate_groups(task: &Task) -> Vec<Vec<ObjectId>> {
    // Objects no fluent fact names (constants a grounding left unused) move nothing.
    let mut named = vec![false; task.objects.len()];
    for atom in &task.facts {
        for o in &atom.args {
            named[o.index()] = true;
        }
    }
    let mut signature: Vec<Signature> = vec![Vec::new(); task.objects.len()];
    for &f in &task.init {
        let atom = task.fact(f);
        for (pos, o) in atom.args.iter().enumerate() {
            signature[o.index()].push((0, atom.predicate.0, pos as u32));
        }
    }
    for disjunct in &task.goal.disjuncts {
        for literal in disjunct.literals() {
            let atom = task.fact(literal.fact());
            for (pos, o) in atom.args.iter().enumerate() {
                signature[o.index()].push((1 + u8::from(literal.is_negated()), atom.predicate.0, pos as u32));
            }
        }
    }
    for action in &task.actions {
        for (pos, o) in action.args.iter().enumerate() {
            signature[o.index()].push((3, action.schema.0, pos as u32));
        }
    }
    let mut groups: HashMap<(Vec<String>, Signature), Vec<ObjectId>> = HashMap::new();
    for (i, mut sig) in signature.into_iter().enumerate().filter(|&(i, _)| named[i]) {
        sig.sort_unstable();
        let mut types = task.objects[i].types.clone();
        types.sort();
        groups.entry((types, sig)).or_default().push(ObjectId(i as u32));
    }
    let mut groups: Vec<Vec<ObjectId>> = groups.into_values().filter(|g| g.len() > 1).collect();
    groups.sort();
    groups
}

/// Every fact a condition names: its literals' and its clauses'.
fn condition_facts(c: &Condition) -> impl Iterator<Item = FactId> + '_ {
    c.pos.iter().chain(&c.neg).copied().chain(c.clauses.iter().flatten().map(|l| l.fact()))
}

/// Every fact an action names, in its precondition, effects and conditional effects.
fn action_facts(a: &grounding::Action) -> impl Iterator<Item = FactId> + '_ {
    condition_facts(&a.pre)
        .chain(a.add.iter().chain(&a.del).copied())
        .chain(a.conditional.iter().flat_map(|c| condition_facts(&c.condition).chain(c.add.iter().chain(&c.del).copied())))
}

/// Checks swaps of two objects of the candidate groups for being automorphisms of one task,
/// looking only at what the swap moves: the facts that name the two objects (each object's
/// list, built once) and the actions that mention them anywhere (likewise).
struct Checker<'t> {
    task: &'t Task,
    fact_index: &'t HashMap<Atom, FactId>,
    action_index: &'t HashMap<ActionName, SmallVec<[ActionId; 2]>>,
    in_init: Vec<bool>,
    goal: HashSet<NormCondition>,
    /// For each object of a candidate group, the facts that name it (empty for the others).
    facts_of: Vec<Vec<FactId>>,
    /// For each object of a candidate group, the actions that name it anywhere, ascending.
    actions_of: Vec<Vec<ActionId>>,
    /// Canonical encodings of the actions an image was compared with, made when first needed.
    encoded: Vec<Option<Box<[u32]>>>,
    /// Scratch, the identity between checks: each fact's image under the swap checked.
    fact_image: Vec<FactId>,
    moved: Vec<FactId>,
    /// Scratch: the last check that listed an action.
    listed: Vec<u32>,
    checks: u32,
    encoder: Encoder,
    /// Scratch: an image's encoding, and the moved parts of an action and of its image.
    image: Vec<u32>,
    before: Encoder,
    after: Encoder,
}

impl<'t> Checker<'t> {
    fn new(
        task: &'t Task,
        fact_index: &'t HashMap<Atom, FactId>,
        action_index: &'t HashMap<ActionName, SmallVec<[ActionId; 2]>>,
        groups: &[Vec<ObjectId>],
    ) -> Checker<'t> {
        // Literal numbers (fact << 1 | negated) stay below the encoder's separators.
        debug_assert!(task.facts.len() < (1 << 31) - 2);
        let mut candidate = vec![false; task.objects.len()];
        for &o in groups.iter().flatten() {
            candidate[o.index()] = true;
        }
        let mut facts_of: Vec<Vec<FactId>> = vec![Vec::new(); task.objects.len()];
        // Per fact, the candidates it names (at most its arity), for the action index below.
        let mut fact_candidates: Vec<SmallVec<[ObjectId; 2]>> = vec![SmallVec::new(); task.facts.len()];
        for (i, atom) in task.facts.iter().enumerate() {
            for &o in &atom.args {
                if candidate[o.index()] && !fact_candidates[i].contains(&o) {
                    fact_candidates[i].push(o);
                    facts_of[o.index()].push(FactId(i as u32));
                }
            }
        }
        let mut actions_of: Vec<Vec<ActionId>> = vec![Vec::new(); task.objects.len()];
        let mut last: Vec<u32> = vec![u32::MAX; task.objects.len()];
        for (i, action) in task.actions.iter().enumerate() {
            let mut note = |o: ObjectId| {
                if last[o.index()] != i as u32 {
                    last[o.index()] = i as u32;
                    actions_of[o.index()].push(ActionId(i as u32));
                }
            };
            for &o in action.args.iter().filter(|o| candidate[o.index()]) {
                note(o);
            }
            for f in action_facts(action) {
                for &o in &fact_candidates[f.index()] {
                    note(o);
                }
            }
        }
        let mut in_init = vec![false; task.facts.len()];
        for &f in &task.init {
            in_init[f.index()] = true;
        }
        Checker {
            task,
            fact_index,
            action_index,
            in_init,
            goal: task.goal.disjuncts.iter().map(|d| NormCondition::of(d, &|f| f)).collect(),
            facts_of,
            actions_of,
            encoded: vec![None; task.actions.len()],
            fact_image: (0..task.facts.len() as u32).map(FactId).collect(),
            moved: Vec::new(),
            listed: vec![0; task.actions.len()],
            checks: 0,
            encoder: Encoder::default(),
            image: Vec::new(),
            before: Encoder::default(),
            after: Encoder::default(),
        }
    }

    /// Whether swapping `a` and `b` maps the task onto itself.
    fn swap_is_automorphism(&mut self, a: ObjectId, b: ObjectId) -> bool {
        let holds = self.map_facts(a, b) && self.check(a, b);
        for &f in &self.moved {
            self.fact_image[f.index()] = f;
        }
        self.moved.clear();
        holds
    }

    /// Fills `fact_image` for the facts that name `a` or `b`; false if one has no image.
    fn map_facts(&mut self, a: ObjectId, b: ObjectId) -> bool {
        for &f in self.facts_of[a.index()].iter().chain(&self.facts_of[b.index()]) {
            if self.fact_image[f.index()] != f {
                continue; // it names both
            }
            let atom = &self.task.facts[f.index()];
            let image = Atom { predicate: atom.predicate, args: atom.args.iter().map(|&o| swap(o, a, b)).collect() };
            // An atom that names a or b differs from its image: the swap moves every such fact.
            let Some(&g) = self.fact_index.get(&image) else { return false };
            self.fact_image[f.index()] = g;
            self.moved.push(f);
        }
        true
    }

    fn check(&mut self, a: ObjectId, b: ObjectId) -> bool {
        let Checker { task, action_index, fact_image, in_init, goal, moved, .. } = self;
        let (task, map) = (*task, |f: FactId| fact_image[f.index()]);
        // The moved facts map onto one another, so init maps onto itself when no initial fact
        // maps outside it.
        if moved.iter().any(|&f| in_init[f.index()] && !in_init[map(f).index()]) {
            return false;
        }
        if task.goal.disjuncts.iter().any(|d| !goal.contains(&NormCondition::of(d, &map))) {
            return false;
        }
        self.checks += 1;
        let stamp = self.checks;
        // `b`'s actions first: `a` stays the same over the checks of its class, so the images
        // found among its actions are encoded once and reused.
        for o in [b, a] {
            for &id in &self.actions_of[o.index()] {
                if self.listed[id.index()] == stamp {
                    continue;
                }
                self.listed[id.index()] = stamp;
                let action = task.action(id);
                let args_move = action.args.iter().any(|&x| x == a || x == b);
                if !args_move && maps_onto_itself(action, &map, &mut self.before, &mut self.after) {
                    continue;
                }
                // The image is an action of the swapped name (split actions share one).
                let args: SmallVec<[ObjectId; 6]> = action.args.iter().map(|&x| swap(x, a, b)).collect();
                let Some(candidates) = action_index.get(&(action.schema.0, args)) else { return false };
                self.encoder.action(action, &map, &mut self.image);
                let (encoder, encoded, image) = (&mut self.encoder, &mut self.encoded, &self.image);
                let found = candidates.iter().copied().find(|&c| {
                    let candidate = task.action(c);
                    candidate.cost == action.cost
                        && **encoded[c.index()].get_or_insert_with(|| {
                            let mut out = Vec::new();
                            encoder.action(candidate, &|f| f, &mut out);
                            out.into_boxed_slice()
                        }) == **image
                });
                let Some(found) = found else { return false };
                // A swap is its own inverse: the image found maps back onto this action, so
                // it needs no check of its own.
                self.listed[found.index()] = stamp;
            }
        }
        true
    }
}

/// `o` under the swap of `a` and `b`.
fn swap(o: ObjectId, a: ObjectId, b: ObjectId) -> ObjectId {
    if o == a {
        b
    } else if o == b {
        a
    } else {
        o
    }
}

/// Whether `map` takes `action` onto itself (as [`NormAction`]s), comparing only the parts
/// that name a fact `map` moves: the precondition if it does, each such add and delete, and
/// the conditional effects that do (a multiset, as `NormAction` keeps them).
fn maps_onto_itself(action: &grounding::Action, map: &dyn Fn(FactId) -> FactId, before: &mut Encoder, after: &mut Encoder) -> bool {
    let moves = |f: FactId| map(f) != f;
    // Sorted sets: each moved fact's image must be in the set (the map is a bijection).
    let closed = |set: &[FactId]| set.iter().all(|&f| !moves(f) || set.binary_search(&map(f)).is_ok());
    if !closed(&action.add) || !closed(&action.del) {
        return false;
    }
    if condition_facts(&action.pre).any(moves) {
        before.begin();
        after.begin();
        before.condition(&action.pre, &|f| f);
        after.condition(&action.pre, map);
        if before.items != after.items {
            return false;
        }
    }
    before.begin();
    after.begin();
    for c in &action.conditional {
        if condition_facts(&c.condition).chain(c.add.iter().chain(&c.del).copied()).any(moves) {
            before.effect(c, &|f| f);
            after.effect(c, map);
        }
    }
    before.sorted_groups() == after.sorted_groups()
}

/// Canonical encodings of actions under a map of facts, into reused buffers: the same
/// sequence of numbers exactly when the mapped [`NormAction`]s are equal. Each set is sorted
/// and without repeats, clauses sorted and without repeats, conditional effects sorted (as a
/// multiset); every part ends with a separator no fact or literal number takes.
#[derive(Debug, Default)]
struct Encoder {
    /// The encoding being built (or the current group's, see [`Encoder::effect`]).
    items: Vec<u32>,
    /// Whole groups (conditional effects) and their ranges in `groups`, to be sorted.
    groups: Vec<u32>,
    ranges: Vec<(u32, u32)>,
    /// Clauses of the condition being encoded, and their ranges.
    clauses: Vec<u32>,
    clause_ranges: Vec<(u32, u32)>,
    sorted: Vec<u32>,
}

const END_SET: u32 = u32::MAX;
const END_CLAUSE: u32 = u32::MAX - 1;
const END_EFFECT: u32 = u32::MAX - 2;

impl Encoder {
    fn begin(&mut self) {
        self.items.clear();
        self.groups.clear();
        self.ranges.clear();
    }

    /// `action` under `map`, into `out`.
    fn action(&mut self, action: &grounding::Action, map: &dyn Fn(FactId) -> FactId, out: &mut Vec<u32>) {
        self.begin();
        self.condition(&action.pre, map);
        self.set(&action.add, map);
        self.set(&action.del, map);
        for c in &action.conditional {
            self.effect(c, map);
        }
        out.clear();
        out.extend_from_slice(&self.items);
        out.extend_from_slice(self.sorted_groups());
    }

    /// A conditional effect as one group, kept apart until [`Encoder::sorted_groups`].
    fn effect(&mut self, c: &grounding::ConditionalEffect, map: &dyn Fn(FactId) -> FactId) {
        let mark = self.items.len();
        self.condition(&c.condition, map);
        self.set(&c.add, map);
        self.set(&c.del, map);
        let start = self.groups.len() as u32;
        self.groups.extend_from_slice(&self.items[mark..]);
        self.groups.push(END_EFFECT);
        self.ranges.push((start, self.groups.len() as u32));
        self.items.truncate(mark);
    }

    /// The groups, sorted (repeats kept), one after another.
    fn sorted_groups(&mut self) -> &[u32] {
        let groups = &self.groups;
        self.ranges.sort_unstable_by(|x, y| groups[x.0 as usize..x.1 as usize].cmp(&groups[y.0 as usize..y.1 as usize]));
        self.sorted.clear();
        for &(s, e) in &self.ranges {
            self.sorted.extend_from_slice(&groups[s as usize..e as usize]);
        }
        &self.sorted
    }

    fn set(&mut self, facts: &[FactId], map: &dyn Fn(FactId) -> FactId) {
        let start = self.items.len();
        self.items.extend(facts.iter().map(|&f| map(f).0));
        sort_dedup_tail(&mut self.items, start);
        self.items.push(END_SET);
    }

    fn condition(&mut self, c: &Condition, map: &dyn Fn(FactId) -> FactId) {
        self.set(&c.pos, map);
        self.set(&c.neg, map);
        self.clauses.clear();
        self.clause_ranges.clear();
        for clause in &c.clauses {
            let start = self.clauses.len();
            self.clauses.extend(clause.iter().map(|l| map(l.fact()).0 << 1 | u32::from(l.is_negated())));
            sort_dedup_tail(&mut self.clauses, start);
            self.clause_ranges.push((start as u32, self.clauses.len() as u32));
        }
        let clauses = &self.clauses;
        let slice = |r: &(u32, u32)| &clauses[r.0 as usize..r.1 as usize];
        self.clause_ranges.sort_unstable_by(|x, y| slice(x).cmp(slice(y)));
        self.clause_ranges.dedup_by(|x, y| slice(x) == slice(y));
        for r in &self.clause_ranges {
            self.items.extend_from_slice(slice(r));
            self.items.push(END_CLAUSE);
        }
        self.items.push(END_SET);
    }
}

/// Sorts `v[start..]` and drops its repeats.
fn sort_dedup_tail(v: &mut Vec<u32>, start: usize) {
    v[start..].sort_unstable();
    let mut kept = start;
    for i in start..v.len() {
        if kept == start || v[i] != v[kept - 1] {
            v[kept] = v[i];
            kept += 1;
        }
    }
    v.truncate(kept);
}

/// `facts` mapped, sorted, without repeats.
fn mapped_set(facts: &[FactId], map: &dyn Fn(FactId) -> FactId) -> Vec<FactId> {
    let mut v: Vec<FactId> = facts.iter().map(|&f| map(f)).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// A condition with its facts mapped and every part sorted, for comparison.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
struct NormCondition {
    pos: Vec<FactId>,
    neg: Vec<FactId>,
    clauses: Vec<Vec<(FactId, bool)>>,
}

impl NormCondition {
    fn of(c: &Condition, map: &dyn Fn(FactId) -> FactId) -> NormCondition {
        let mut clauses: Vec<Vec<(FactId, bool)>> = c
            .clauses
            .iter()
            .map(|clause| {
                let mut v: Vec<(FactId, bool)> = clause.iter().map(|l| (map(l.fact()), l.is_negated())).collect();
                v.sort_unstable();
                v.dedup();
                v
            })
            .collect();
        clauses.sort();
        clauses.dedup();
        NormCondition { pos: mapped_set(&c.pos, map), neg: mapped_set(&c.neg, map), clauses }
    }
}

#[derive(Debug, PartialEq, Eq)]
struct NormAction {
    pre: NormCondition,
    add: Vec<FactId>,
    del: Vec<FactId>,
    conditional: Vec<(NormCondition, Vec<FactId>, Vec<FactId>)>,
}

impl NormAction {
    fn of(a: &grounding::Action, map: &dyn Fn(FactId) -> FactId) -> NormAction {
        let mut conditional: Vec<(NormCondition, Vec<FactId>, Vec<FactId>)> = a
            .conditional
            .iter()
            .map(|c| (NormCondition::of(&c.condition, map), mapped_set(&c.add, map), mapped_set(&c.del, map)))
            .collect();
        conditional.sort();
        NormAction { pre: NormCondition::of(&a.pre, map), add: mapped_set(&a.add, map), del: mapped_set(&a.del, map), conditional }
    }
}
