#!/usr/bin/env python3
"""Which EAI tasks a class-level agent can get right at all: EAI's judge checks the node ids
its goals name, while the agent is told classes (exploration-harness's goal parser). A goal
node is identifiable when it is the only instance of its class in the scene, or the only one
not already in every state the goal gives it (the rule `VirtualhomeAdapter::already_done`
applies: a task asks for a change; only for a goal node the goal relates to no other object).
Otherwise it is ambiguous: the agent can only guess which instance the judge means.

Usage:
    eai_goal_instances.py TASK_DIR [RECORDS.jsonl...]
        TASK_DIR: the folder `cargo xtask fetch-data` prints (or fixtures/virtualhome-eai/graphs).
        Prints the tasks by category; with `cargo xtask eval --benchmark virtualhome-eai`
        records, the tasks won and the failures by attribution within each category.

Reads only the benchmark's own task files and the records; no network.
"""

import collections
import glob
import gzip
import json
import os
import sys


def category(task):
    nodes = {n["id"]: n for n in task["init_graph"]["nodes"]}
    by_class = collections.defaultdict(list)
    for n in nodes.values():
        by_class[n["class_name"]].append(n["id"])
    states = collections.defaultdict(set)
    related = set()  # goal nodes the goal relates to another object
    goal_nodes = set()
    for g in task["vh_goal"]["goal"]:
        if "id" in g:
            states[g["id"]].add(g["state"])
            goal_nodes.add(g["id"])
            continue
        ends = [g["from_id"], g["to_id"]]
        objects = [i for i in ends if nodes.get(i, {}).get("class_name") != "character"]
        goal_nodes.update(objects)
        if len(objects) == 2:
            related.update(objects)
    verdict = "unique"
    for i in sorted(goal_nodes):
        if i not in nodes:
            return "missing"
        others = by_class[nodes[i]["class_name"]]
        if len(others) == 1:
            continue
        if states[i] and i not in related:
            open_ = [j for j in others if not states[i] <= set(nodes[j]["states"])]
            if open_ == [i]:
                verdict = "identified by its states"
                continue
        return "ambiguous"
    return verdict


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    paths = sorted(glob.glob(os.path.join(argv[1], "*.json.gz")))
    if not paths:
        print(f"{argv[1]}: no *.json.gz task files", file=sys.stderr)
        return 2
    cats = {}
    for p in paths:
        with gzip.open(p, "rt") as f:
            task = json.load(f)
        cats[task["task_id"]] = category(task)
    records = {}
    for r in argv[2:]:
        with open(r) as f:
            for line in f:
                line = line.strip()
                if line:
                    rec = json.loads(line)
                    records[rec["task"]] = rec
    for c, n in sorted(collections.Counter(cats.values()).items()):
        line = f"{c:<26} {n:>4} tasks"
        judged = [records[t] for t, k in cats.items() if k == c and t in records]
        if judged:
            won = sum(r["success"] for r in judged)
            why = collections.Counter(r["attribution"] for r in judged if not r["success"])
            line += f"   won {won}/{len(judged)}   failures {dict(why)}"
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
