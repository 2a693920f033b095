#!/usr/bin/env python3
"""Export EAI VirtualHome tasks as fixtures, and record what the real evolving graph does
with programs on them (the reference our VirtualhomeEnv must reproduce).

Usage:
    virtualhome_record.py export OUT_DIR [--tasks ID,ID,...]
        One gzip file per task, OUT_DIR/<id>.json.gz: {task_id, task_name, description,
        vh_goal, init_graph}, from the eai-eval 1.0.5 wheel (init graph of
        init_and_final_graphs/.../file<id>.json, the program file's title and description,
        vh_goal of resources/virtualhome/task_state_LTL_formula_accurate.json). Default
        tasks: the 33 kitchen tasks copied to ../shared/data/virtualhome-eai.
    virtualhome_record.py record TASK_DIR OUT.jsonl.gz [--random K] [--steps N] [--shard I/N]
    virtualhome_record.py merge OUT.jsonl.gz PART.jsonl.gz...
    virtualhome_record.py time TASK_ID...
        Times the real executor per task: building the planner on the task's init graph (read
        from the dataset, as EAI does: "load and reset") and every line of EAI's gold program;
        one JSON line per task {task, reset_s, steps, step_s (all steps together)}.
    virtualhome_record.py check SOUNDNESS.jsonl OUT.jsonl [--shard I/N] [--task-dir DIR]
        The sound domain's figures: for every record of `cargo xtask soundness` (the file it
        prints), EAI's gold program, the A* plan's script (`script`) and the rewritten gold PDDL
        plan's script
        (`gold_script`) run in the real evolving graph, each judged on every goal; one JSON line
        per task {task, gold_program_ok, a_executed, a_goal, b_executed, b_goal, ...}, and the
        counts on standard error. Exit 1 when an A* plan fails on a task whose gold program
        reaches its goal (the domain would not be sound).
        For every task file in TASK_DIR: EAI's gold program and K random programs of N
        steps (default 5 and 15; seeds 0..K-1), one JSON line each:
        {task, program, lines, executed, messages, goal, unmet}.

How programs run: each line through MotionPlanner.my_execute_primitive_action_eval, as
EAI's action-sequencing evaluation does; a line that fails leaves the state unchanged and
the program goes on (the executor's own behaviour; EAI's evaluation would stop there, so
its first failing step is the first `false` in `executed`). `goal` checks every node,
edge and action goal on the final state (not EAI's scene_evaluate_wID, which stops after
the first satisfied edge goal); action goals see the executed lines only.

Random programs: random.Random("<task>/<seed>"); at each step an action drawn from
RANDOM_ACTIONS by weight and objects drawn from what get_visible_nodes's rule shows then
(visible_nodes; sorted ids, the character, walls, floors and ceilings left out): with
probability 0.6 among the visible nodes the character has a
CLOSE edge to (when there are any), else among all visible nodes; the first object of a
two-object action is a held object with probability 0.8 when one is held.

Runs under the venv made by `../shared/anchors/install.sh virtualhome` (re-executes itself
there with PYTHONHASHSEED=0: get_visible_nodes reads edges in an order that depends on it).
"""
import argparse
import copy
import gzip
import json
import logging
import os
import random
import signal
import sys

# (action, weight): moving and grabbing often, so that the programs reach the effects.
RANDOM_ACTIONS = [("WALK", 5), ("FIND", 2), ("GRAB", 4), ("OPEN", 3), ("CLOSE", 2), ("PUTBACK", 3),
                  ("PUTIN", 3), ("SWITCHON", 2), ("SWITCHOFF", 1), ("TURNTO", 1), ("LOOKAT", 1),
                  ("WIPE", 1), ("TOUCH", 1), ("POUR", 1), ("DRINK", 1), ("READ", 1), ("PLUGIN", 1),
                  ("PLUGOUT", 1), ("WASH", 1), ("PUSH", 1), ("PULL", 1), ("SIT", 1), ("STANDUP", 1),
                  ("WATCH", 1), ("TYPE", 1), ("DROP", 1)]
# Structure the random programs do not pick (they are visible, but rarely worth an action).
SKIPPED_CATEGORIES = {"Walls", "Ceiling", "Floor", "Floors"}
TWO_OBJECTS = {"PUTBACK", "PUTIN", "POUR"}
NO_OBJECT = {"STANDUP"}
# A line the executor has not finished after this long (a minute: a loaded machine makes
# ordinary steps take seconds) (it loops forever following a cycle of
# INSIDE edges in _get_room_node) counts as not executed; the state is left as it was.
STEP_LIMIT_S = 60.0
KITCHEN = ("Wash_dishes_with_dishwasher", "Put_groceries_in_Fridge", "Cook_some_food",
           "Set_up_table", "Make_coffee")


def reexec():
    venv = os.environ.get("ANCHOR_VENV", os.path.expanduser("~/.cache/nsea-anchors/venv"))
    py = os.path.join(venv, "bin", "python")
    if not os.path.exists(py):
        sys.exit("engine not installed: run ../shared/anchors/install.sh virtualhome")
    env = dict(os.environ, PYTHONHASHSEED="0", NSEA_VH_REEXEC="1")
    os.execve(py, [py] + sys.argv, env)


if os.environ.get("NSEA_VH_REEXEC") != "1":
    reexec()

logging.disable(logging.CRITICAL)
import virtualhome_eval  # noqa: E402
from virtualhome_eval.simulation.evolving_graph import utils  # noqa: E402
from virtualhome_eval.simulation.evolving_graph.eval_utils import (  # noqa: E402
    construct_planner, extract_script, check_order_with_or_score)

PKG = os.path.dirname(virtualhome_eval.__file__)
RES = os.path.join(PKG, "resources", "virtualhome")
ROOT = os.path.join(PKG, "dataset", "programs_processed_precond_nograb_morepreconds")
SUB = os.path.join("TrimmedTestScene1_graph", "results_intentions_march-13-18")


def id2task():
    return json.load(open(os.path.join(RES, "id2task.json")))


def goals_of(task_id):
    if task_id in TASK_FILES:
        return TASK_FILES[task_id]["vh_goal"]
    task = id2task()[task_id]
    return json.load(open(os.path.join(RES, "task_state_LTL_formula_accurate.json")))["scene_1"][task][task_id]["vh_goal"]


def export(out_dir, tasks):
    os.makedirs(out_dir, exist_ok=True)
    names = id2task()
    for tid in tasks:
        graph = json.load(open(os.path.join(ROOT, "init_and_final_graphs", SUB, f"file{tid}.json")))["init_graph"]
        title, description, _ = extract_script(os.path.join(ROOT, "executable_programs", SUB, f"file{tid}.txt"))
        record = {"task_id": tid, "task_name": names[tid], "description": description.strip(),
                  "vh_goal": goals_of(tid), "init_graph": graph}
        data = json.dumps(record, separators=(",", ":"), sort_keys=True).encode()
        with open(os.path.join(out_dir, f"{tid}.json.gz"), "wb") as f:
            f.write(gzip.compress(data, compresslevel=9, mtime=0))
    print(f"exported {len(tasks)} tasks to {out_dir}")


def strict_goal(planner, vh_goal, history):
    final = planner.env_state.to_dict()
    states = {n["id"]: set(n["states"]) for n in final["nodes"]}
    edges = {(e["from_id"], e["relation_type"], e["to_id"]) for e in final["edges"]}
    unmet = []
    for g in vh_goal["goal"]:
        if "state" in g:
            if g["state"] not in states.get(g["id"], set()):
                unmet.append(g)
        elif (g["from_id"], g["relation_type"], g["to_id"]) not in edges:
            unmet.append(g)
    actions = list(dict.fromkeys(vh_goal["actions"]))
    if actions:
        _, missing = check_order_with_or_score(actions, " ".join(history))
        unmet += missing
    return not unmet, unmet


class StepTimeout(Exception):
    pass


def on_alarm(signum, frame):
    raise StepTimeout()


def run(planner, lines):
    executed, messages, history = [], [], []
    signal.signal(signal.SIGALRM, on_alarm)
    for n, line in enumerate(lines, 1):
        try:
            signal.setitimer(signal.ITIMER_REAL, STEP_LIMIT_S)
            try:
                ok, info = planner.my_execute_primitive_action_eval(line)
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
            msg = info.get_error_string()
        except StepTimeout:
            ok, msg = False, f"executor did not finish within {STEP_LIMIT_S} s"
        except Exception as e:  # noqa: BLE001 - the executor raises on some bad lines
            ok, msg = False, f"exception: {e!r}"
        executed.append(bool(ok))
        messages.append("" if ok else msg)
        if ok:
            history.append(line)
    return executed, messages, history


# Task files that are not EAI tasks (the rearrangement set): id -> the file's JSON.
TASK_FILES = {}


def new_planner(tid):
    """The executor on the task's init graph and the task's reference program: EAI's gold
    program for an EAI task, `reference_program` for a task file registered in TASK_FILES."""
    if tid in TASK_FILES:
        from virtualhome_eval.simulation.evolving_graph.environment import EnvironmentGraph
        from virtualhome_eval.simulation.evolving_graph.motion_planner import MotionPlanner
        task = TASK_FILES[tid]
        planner = MotionPlanner(EnvironmentGraph(copy.deepcopy(task["init_graph"])), copy.deepcopy(task["init_graph"]),
                                acting_char_id=65)
        return planner, list(task.get("reference_program", []))
    planner, _, gold, _, _ = construct_planner(
        utils.load_name_equivalence(), utils.load_properties_data(), utils.load_object_placing(),
        scenegraph_id=1, script_id=tid, dataset_root=ROOT)
    return planner, gold


def register_task_files(task_dir):
    for name in sorted(os.listdir(task_dir)):
        if name.endswith(".json.gz"):
            task = json.load(gzip.open(os.path.join(task_dir, name), "rt"))
            if task["task_id"] not in id2task():
                TASK_FILES[task["task_id"]] = task


def visible_nodes(state, char):
    """utils.get_visible_nodes's rule ({id: class_name}): the nodes transitively INSIDE the
    character's room, less those INSIDE a non-room node that is not OPEN, plus every room
    and what the character holds. Ported with a visited set: EAI's loops forever, growing
    its lists, once POUR has made a cycle of INSIDE edges (pouring a thing into itself)."""
    nodes = {n["id"]: n for n in state["nodes"]}
    inside_of, contents, held = {}, {}, []
    for e in state["edges"]:
        if e["relation_type"] == "INSIDE":
            inside_of.setdefault(e["from_id"], []).append(e["to_id"])
            contents.setdefault(e["to_id"], []).append(e["from_id"])
        elif e["relation_type"].startswith("HOLDS") and e["from_id"] == char:
            held.append(e["to_id"])
    rooms = [i for i, n in nodes.items() if n["category"] == "Rooms"]
    seen, frontier = set(), [r for r in inside_of.get(char, []) if r in rooms]
    frontier = [o for r in frontier for o in contents.get(r, [])]
    while frontier:
        o = frontier.pop()
        if o not in seen:
            seen.add(o)
            frontier += contents.get(o, [])

    def hidden(o):
        return any(p not in rooms and "OPEN" not in nodes[p]["states"] for p in inside_of.get(o, []))

    ids = {o for o in seen if not hidden(o)} | set(rooms) | set(held)
    return {i: nodes[i]["class_name"] for i in ids}


def random_program(tid, seed, steps):
    """The program's lines, and the planner that ran them (each line ran once as drawn)."""
    planner, _ = new_planner(tid)
    rng = random.Random(f"{tid}/{seed}")
    char = planner.acting_char_id
    lines, executed, messages, history = [], [], [], []
    for _ in range(steps):
        state = planner.env_state.to_dict()
        names = visible_nodes(state, char)
        categories = {n["id"]: n["category"] for n in state["nodes"]}
        objs = sorted(i for i, n in names.items() if i != char and categories[i] not in SKIPPED_CATEGORIES)
        close = sorted({e["to_id"] for e in state["edges"]
                        if e["from_id"] == char and e["relation_type"] == "CLOSE" and e["to_id"] in names} - {char})
        held = sorted({e["to_id"] for e in state["edges"]
                       if e["from_id"] == char and e["relation_type"].startswith("HOLDS")})

        def pick():
            pool = close if close and rng.random() < 0.6 else objs
            return rng.choice(pool)

        act = rng.choices([a for a, _ in RANDOM_ACTIONS], weights=[w for _, w in RANDOM_ACTIONS])[0]
        if act in NO_OBJECT:
            line = f"[{act}]"
        elif act in TWO_OBJECTS:
            src = rng.choice(held) if held and rng.random() < 0.8 else pick()
            dest = pick()
            line = f"[{act}] <{names.get(src, 'x')}> ({src}) <{names[dest]}> ({dest})"
        else:
            o = pick()
            line = f"[{act}] <{names[o]}> ({o})"
        lines.append(line)
        ok, msg, hist = run(planner, [line])
        executed += ok
        messages += msg
        history += hist
    return lines, planner, (executed, messages, history)


def record(task_dir, out, k, steps, shard):
    tasks = sorted(f[:-len(".json.gz")] for f in os.listdir(task_dir) if f.endswith(".json.gz"))
    index, count = shard
    tasks = tasks[index::count]
    rows = []
    for tid in tasks:
        print(f"task {tid}", file=sys.stderr, flush=True)
        vh_goal = goals_of(tid)
        planner, gold = new_planner(tid)
        runs = [("gold", list(gold), planner, run(planner, list(gold)))]
        for s in range(k):
            lines, planner, result = random_program(tid, s, steps)
            runs.append((f"random-{s}", lines, planner, result))
        for name, lines, planner, (executed, messages, history) in runs:
            ok, unmet = strict_goal(planner, vh_goal, history)
            rows.append({"task": tid, "program": name, "lines": lines, "executed": executed,
                         "messages": messages, "goal": ok, "unmet": [json.dumps(u) if isinstance(u, dict) else u for u in unmet]})
    write_rows(out, rows)
    print(f"recorded {len(rows)} programs on {len(tasks)} tasks to {out}")


def time_tasks(tasks):
    import time
    for tid in tasks:
        start = time.perf_counter()
        planner, gold = new_planner(tid)
        reset_s = time.perf_counter() - start
        start = time.perf_counter()
        for line in gold:
            planner.my_execute_primitive_action_eval(line)
        step_s = time.perf_counter() - start
        print(json.dumps({"task": tid, "reset_s": reset_s, "steps": len(gold), "step_s": step_s}), flush=True)


def check(plans, out, shard):
    index, count = shard
    rows = [json.loads(line) for line in open(plans)][index::count]
    counts = {"tasks": 0, "gold_program_ok": 0, "a_ok": 0, "a_ok_given_gold": 0, "b_plans": 0,
              "b_ok": 0, "b_ok_given_gold": 0, "b_gold_tasks": 0, "b_valid": 0, "b_valid_ok": 0}
    with open(out, "w") as f:
        for row in rows:
            tid = row["task"]
            print(f"task {tid}", file=sys.stderr, flush=True)
            vh_goal = goals_of(tid)
            result = {"task": tid}
            planner, gold = new_planner(tid)
            executed, messages, history = run(planner, list(gold))
            gold_ok = all(executed) and strict_goal(planner, vh_goal, history)[0]
            result["gold_program_ok"] = gold_ok
            for key, tag in (("script", "a"), ("gold_script", "b")):
                if key not in row:
                    continue
                planner, _ = new_planner(tid)
                executed, messages, history = run(planner, row[key])
                ok, unmet = strict_goal(planner, vh_goal, history)
                result[f"{tag}_executed"] = all(executed)
                result[f"{tag}_goal"] = ok
                result[f"{tag}_failed"] = [f"{n}: {row[key][n]}: {m}" for n, m in enumerate(messages) if m][:1]
                result[f"{tag}_unmet"] = [json.dumps(u) if isinstance(u, dict) else u for u in unmet]
            a_ok = result.get("a_executed", False) and result.get("a_goal", False)
            b_ok = result.get("b_executed", False) and result.get("b_goal", False)
            counts["tasks"] += 1
            counts["gold_program_ok"] += gold_ok
            counts["a_ok"] += a_ok
            counts["a_ok_given_gold"] += gold_ok and a_ok
            if "gold_script" in row:
                counts["b_plans"] += 1
                counts["b_ok"] += b_ok
                counts["b_gold_tasks"] += gold_ok
                counts["b_ok_given_gold"] += gold_ok and b_ok
                counts["b_valid"] += bool(row.get("gold_valid"))
                counts["b_valid_ok"] += bool(row.get("gold_valid")) and b_ok
            f.write(json.dumps(result, separators=(",", ":")) + "\n")
            f.flush()
    print(json.dumps(counts), file=sys.stderr)
    # Exit 1 when an A* plan fails where the gold program succeeds: the domain is not sound.
    return 0 if counts["a_ok_given_gold"] == counts["gold_program_ok"] else 1


def write_rows(out, rows):
    data = "".join(json.dumps(r, separators=(",", ":")) + "\n" for r in rows).encode()
    with open(out, "wb") as f:
        f.write(gzip.compress(data, compresslevel=9, mtime=0))


def merge(out, parts):
    """Merges shard recordings into one, ordered by task, then gold and random-0, -1, ..."""
    rows = [json.loads(line) for p in parts for line in gzip.open(p, "rt")]
    order = lambda r: (r["task"], -1 if r["program"] == "gold" else int(r["program"].split("-")[1]))  # noqa: E731
    write_rows(out, sorted(rows, key=order))
    print(f"merged {len(rows)} programs into {out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("export")
    e.add_argument("out_dir")
    e.add_argument("--tasks", help="comma-separated task ids (default: the 33 kitchen tasks)")
    r = sub.add_parser("record")
    r.add_argument("task_dir")
    r.add_argument("out")
    r.add_argument("--random", type=int, default=5)
    r.add_argument("--steps", type=int, default=15)
    r.add_argument("--shard", default="0/1", help="I/N: every N-th task from the I-th (sorted ids)")
    t = sub.add_parser("time")
    t.add_argument("tasks", nargs="+")
    c = sub.add_parser("check")
    c.add_argument("plans")
    c.add_argument("out")
    c.add_argument("--shard", default="0/1")
    c.add_argument("--task-dir", help="task files of tasks that are not EAI's (their reference_program is the gold program)")
    m = sub.add_parser("merge")
    m.add_argument("out")
    m.add_argument("parts", nargs="+")
    args = ap.parse_args()
    if args.cmd == "export":
        if args.tasks:
            tasks = args.tasks.split(",")
        else:
            names = id2task()
            tasks = sorted(t for t, n in names.items() if n.replace(" ", "_") in KITCHEN
                           and os.path.exists(os.path.join(ROOT, "init_and_final_graphs", SUB, f"file{t}.json")))
        export(args.out_dir, tasks)
    elif args.cmd == "time":
        time_tasks(args.tasks)
    elif args.cmd == "check":
        index, count = (int(x) for x in args.shard.split("/"))
        if args.task_dir:
            register_task_files(args.task_dir)
        sys.exit(check(args.plans, args.out, (index, count)))
    elif args.cmd == "merge":
        merge(args.out, args.parts)
    else:
        index, count = (int(x) for x in args.shard.split("/"))
        record(args.task_dir, args.out, args.random, args.steps, (index, count))


if __name__ == "__main__":
    main()
