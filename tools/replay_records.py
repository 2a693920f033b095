#!/usr/bin/env python3
"""Replay evaluation records in the benchmarks' own engines: every episode an agent played in our
environments (`cargo xtask eval`'s records: ours, the Phase II conditions, the planner, the
direct policy) run again, command for command, in ALFWorld's TextWorld engine or EAI's
evolving graph, and the engine's verdict set beside the record's.

Usage:
    replay_records.py RECORDS.jsonl... [--out OUT.jsonl] [--fixtures DIR] [--task-dir DIR]
                      [--shard I/N] [--require-all]

Each record file is read with the configuration beside it (`<stem>.config.json`; a shard file
`<stem>.shard-I-of-N.jsonl` reads its run's `<stem>.config.json`), which names the benchmark.
Every record's `episode.engine_script` holds the commands as the engine takes them, each with
whether our environment executed it (`Judge::engine_script`):
- ALFWorld (`alfworld-seen`, `alfworld-train`): every command sent, as sent, into the game
  (`fixtures/alfworld/valid_seen|valid_train/<task>/game.tw-pddl`) loaded as ALFWorld's
  evaluation loads it (alfworld_record.py); TextWorld executes a command when its stripped
  text is one of the admissible commands before the step (`_valid_commands`), and answers
  "Nothing happens." otherwise. Agreement: the same outcome at every step, the engine not
  won before the last command, and won at the end exactly when the record says success.
- VirtualHome (`virtualhome-eai`, `virtualhome-rearrange`): every grounded script line,
  executed or refused here, through EAI's executor (virtualhome_record.py's `run`: a refused
  line leaves the state as it was and the program goes on); the goal judged on the final
  state with every node, edge and action goal (`strict_goal`). Agreement: the same outcome
  at every line and the same verdict. EAI tasks come from the installed eai-eval dataset;
  the rearrangement set's from `--task-dir` (default `fixtures/virtualhome-rearrange`).

One JSON line per record on --out (default: standard output): {file, task, agent, success,
engine_success, lines, agree, disagreement}; records that cannot be replayed (the expert's,
which are not episodes; records written before `engine_script` existed; torn lines) are
counted and listed on standard error, never silently left out. The counts go to standard
error as one JSON object. Exit 0 when every replayed record agrees, 1 when one does not (or
none could be replayed, or with --require-all one could not be),
2 on bad input (a missing file or configuration, files of both engines in one call: the
engines live in different virtual environments, so run once per engine).

Runs under the venvs made by ../shared/anchors/install.sh alfworld|virtualhome (re-executes
itself there).
"""
import argparse
import json
import os
import re
import sys

TOOLS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TOOLS)
ALFWORLD = {"alfworld-seen": "valid_seen", "alfworld-train": "valid_train"}
VIRTUALHOME = ("virtualhome-eai", "virtualhome-rearrange")


def bad_input(message):
    print(f"replay_records.py: {message}", file=sys.stderr)
    sys.exit(2)


def config_of(path):
    """The run's configuration beside a record file (a shard's: its run's)."""
    stem = re.sub(r"\.shard-\d+-of-\d+$", "", os.path.basename(path)[:-len(".jsonl")])
    config_path = os.path.join(os.path.dirname(path), f"{stem}.config.json")
    try:
        with open(config_path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        bad_input(f"{path}: its configuration {config_path} cannot be read: {e}")


def read_records(path, skipped):
    """The file's records in order; a line that is not a JSON object is reported and kept out."""
    out = []
    try:
        lines = open(path, encoding="utf-8").read().split("\n")
    except OSError as e:
        bad_input(f"{path}: {e}")
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
            if not isinstance(record, dict):
                raise ValueError("not an object")
        except ValueError as e:
            skipped.append(f"{path}:{number}: not a record ({e})")
            continue
        out.append(record)
    return out


def compare(record, outcomes, engine_success, engine_won_early=None):
    """The first disagreement between the record and the engine, or None."""
    script = record["episode"]["engine_script"]
    for n, (line, engine_executed) in enumerate(zip(script, outcomes), 1):
        # In line order: a game won before this line is the first thing that went differently.
        if engine_won_early is not None and n > engine_won_early:
            return f"the engine's game was won at line {engine_won_early} of {len(script)}; line {n} {line['line']!r} came after"
        if line["executed"] != engine_executed:
            ours = "executed" if line["executed"] else "refused"
            theirs = "executed" if engine_executed else "refused"
            return f"line {n} {line['line']!r}: {ours} here, {theirs} by the engine"
    if bool(record["success"]) != engine_success:
        return f"success {record['success']} here, {engine_success} by the engine"
    return None


class Alfworld:
    """TextWorld's PDDL engine with ALFWorld's evaluation wrappers, one game loaded at a time."""

    def __init__(self, fixtures):
        sys.path.insert(0, TOOLS)
        import alfworld_record
        try:
            import textworld  # noqa: F401
        except ImportError:
            alfworld_record.reexec_in_anchor_venv()
        alfworld_record.memoize_parsers()
        self.record = alfworld_record
        self.fixtures = fixtures
        self.game = None
        self.env = None

    def load(self, split, task):
        path = os.path.abspath(os.path.join(self.fixtures, "alfworld", split, task, "game.tw-pddl"))
        if self.game == path:
            return
        if self.env is not None:
            self.env.close()
        if not os.path.exists(path):
            bad_input(f"no game {path} (--fixtures)")
        self.env = self.record.make_env(path)
        self.game = path

    def replay(self, config, record):
        self.load(ALFWORLD[config["benchmark"]], record["task"])
        _obs, infos = self.env.reset()
        won = bool(infos["won"][0])
        outcomes, won_early = [], None
        script = record["episode"]["engine_script"]
        for n, line in enumerate(script, 1):
            if won and won_early is None:
                won_early = n - 1
            admissible = set(infos["admissible_commands"][0])
            outcomes.append(line["line"].strip() in admissible)
            _obs, _scores, _dones, infos = self.env.step([line["line"]])
            won = bool(infos["won"][0])
        return outcomes, won, won_early


class Virtualhome:
    """EAI's evolving graph, through virtualhome_record.py's executor and goal check."""

    def __init__(self, task_dir):
        sys.path.insert(0, TOOLS)
        import virtualhome_record  # re-executes this script in the engine's venv
        self.vh = virtualhome_record
        self.task_dir = task_dir
        self.registered = False

    def replay(self, config, record):
        if config["benchmark"] == "virtualhome-rearrange" and not self.registered:
            self.vh.register_task_files(self.task_dir)
            self.registered = True
        task = record["task"]
        planner, _ = self.vh.new_planner(task)
        lines = [line["line"] for line in record["episode"]["engine_script"]]
        executed, _messages, history = self.vh.run(planner, lines)
        ok, _unmet = self.vh.strict_goal(planner, self.vh.goals_of(task), history)
        return executed, ok, None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", nargs="+")
    ap.add_argument("--out", help="one JSON line per replayed record (default: standard output)")
    ap.add_argument("--fixtures", default=os.path.join(ROOT, "fixtures"))
    ap.add_argument("--task-dir", default=None, help="the rearrangement set's task files (default: FIXTURES/virtualhome-rearrange)")
    ap.add_argument("--shard", default="1/1", help="I/N: every N-th record from the I-th (1-based)")
    ap.add_argument("--require-all", action="store_true", help="exit 1 when a record cannot be replayed or a line is torn")
    args = ap.parse_args()
    try:
        index, count = (int(x) for x in args.shard.split("/"))
        if not 1 <= index <= count:
            raise ValueError
    except ValueError:
        bad_input(f"--shard {args.shard}: expected I/N with 1 <= I <= N")

    skipped = []
    files = []
    for path in args.records:
        if not path.endswith(".jsonl"):
            bad_input(f"{path}: not a record file (*.jsonl)")
        config = config_of(path)
        benchmark = config.get("benchmark")
        if benchmark not in ALFWORLD and benchmark not in VIRTUALHOME:
            bad_input(f"{path}: unknown benchmark {benchmark!r} in its configuration")
        files.append((path, config, read_records(path, skipped)))
    engines = {"alfworld" if c["benchmark"] in ALFWORLD else "virtualhome" for _, c, _ in files}
    if len(engines) > 1:
        bad_input("files of both engines: run once for the ALFWorld records and once for the VirtualHome ones")
    if engines == {"alfworld"}:
        engine = Alfworld(args.fixtures)
    else:
        engine = Virtualhome(args.task_dir or os.path.join(args.fixtures, "virtualhome-rearrange"))

    counts = {"records": 0, "replayed": 0, "agree": 0, "disagree": 0, "won_here": 0, "won_by_engine": 0, "not_replayable": 0}
    out = open(args.out, "w", encoding="utf-8") if args.out else sys.stdout
    position = 0
    for path, config, records in files:
        for record in records:
            position += 1
            if (position - 1) % count != index - 1:
                continue
            counts["records"] += 1
            episode = record.get("episode")
            if not isinstance(episode, dict) or "engine_script" not in episode:
                why = "the expert's record is not an episode" if record.get("agent") == "expert" else "recorded before engine_script"
                skipped.append(f"{path}: {record.get('task')}: not replayable ({why})")
                counts["not_replayable"] += 1
                continue
            print(f"{os.path.basename(path)}: {record['task']}", file=sys.stderr, flush=True)
            outcomes, engine_success, won_early = engine.replay(config, record)
            disagreement = compare(record, outcomes, engine_success, won_early)
            counts["replayed"] += 1
            counts["agree" if disagreement is None else "disagree"] += 1
            counts["won_here"] += bool(record["success"])
            counts["won_by_engine"] += engine_success
            row = {"file": os.path.basename(path), "task": record["task"], "agent": record.get("agent"),
                   "success": bool(record["success"]), "engine_success": engine_success,
                   "lines": len(episode["engine_script"]), "agree": disagreement is None, "disagreement": disagreement}
            out.write(json.dumps(row, separators=(",", ":")) + "\n")
            out.flush()
    for line in skipped:
        print(line, file=sys.stderr)
    print(json.dumps(counts), file=sys.stderr)
    if counts["replayed"] == 0:
        print("replay_records.py: no record could be replayed", file=sys.stderr)
        return 1
    if args.require_all and skipped:
        print(f"replay_records.py: --require-all: {len(skipped)} record(s) or line(s) not replayed", file=sys.stderr)
        return 1
    return 0 if counts["disagree"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
