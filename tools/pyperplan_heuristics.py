#!/usr/bin/env python3
"""Heuristic values and evaluation time in pyperplan 2.1, the reference beside our heuristics in
`cargo xtask bench heuristic`: the same task and the same states, evaluated by pyperplan's own
h_max, h_add, h_FF and LM-cut.

Usage:
    pyperplan_heuristics.py DOMAIN PROBLEM STATES.json RUNS

STATES.json is {"facts": [...], "states": [[...], ...]}: every fact of our grounded task, and each
state as the list of its true facts, all as `(pred a b)`. A state is given to pyperplan as its
facts that pyperplan's grounded task has, and each fact pyperplan has that our task does not (our
grounding leaves out facts no action changes) as pyperplan's initial state has it: such a fact
holds in every state or in none. Prints one JSON object:
    {"facts": N, "operators": N, "states": N,
     "heuristics": {"hmax": {"seconds_per_evaluation": S, "values": [h or null, ...]}, ...}}
where S is the median over RUNS passes over all states of the pass's time divided by the number
of states, and null stands for a dead end (pyperplan's infinity). pyperplan parses STRIPS with
typing only: a domain with `:action-costs` or `=` is refused by its parser (exit 1, the parser's
message on stderr).
"""

import json
import statistics
import sys
import time

from pyperplan.grounding import ground
from pyperplan.heuristics.lm_cut import LmCutHeuristic
from pyperplan.heuristics.relaxation import hAddHeuristic, hFFHeuristic, hMaxHeuristic
from pyperplan.pddl.parser import Parser
from pyperplan.search.searchspace import make_root_node

HEURISTICS = {"hmax": hMaxHeuristic, "hadd": hAddHeuristic, "ff": hFFHeuristic, "lmcut": LmCutHeuristic}


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    domain, problem, states_path, runs = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    parser = Parser(domain, problem)
    task = ground(parser.parse_problem(parser.parse_domain()))
    with open(states_path) as f:
        given = json.load(f)
    ours = {fact.lower() for fact in given["facts"]}
    static_true = (task.facts - ours) & task.initial_state
    states = [(frozenset(fact.lower() for fact in state) & task.facts) | static_true for state in given["states"]]
    nodes = [make_root_node(state) for state in states]
    out = {"facts": len(task.facts), "operators": len(task.operators), "states": len(states), "heuristics": {}}
    for name, make in HEURISTICS.items():
        heuristic = make(task)
        values = [heuristic(node) for node in nodes]
        per_pass = []
        for _ in range(max(runs, 1)):
            start = time.perf_counter()
            for node in nodes:
                heuristic(node)
            per_pass.append((time.perf_counter() - start) / max(len(nodes), 1))
        out["heuristics"][name] = {
            "seconds_per_evaluation": statistics.median(per_pass),
            "values": [None if v == float("inf") else int(v) for v in values],
        }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
