#!/usr/bin/env python3
"""Record the real ALFWorld text engine's reference traces for many games in one process.

Same engine, same loading and the same JSON lines as ../shared/anchors/alfworld_trace.py
(TextWorld 1.7.0 PDDL engine, alfworld 0.4.2 wrappers AlfredDemangler(shuffle=False) and
AlfredInfos, batch 1; a random walk draws each command from the sorted admissible list with
random.Random(seed)), but the game is loaded once and reset for each trace, and Python starts
once for all games, which makes recording every fixture game affordable. Each output line is
alfworld_trace.py's line with two keys put first: "game" (the game folder relative to the
fixtures root) and "trace" ("walkthrough" or "random-N-seed-S").

Usage:
    alfworld_record.py FIXTURES_ROOT OUT.jsonl GAME_DIR... [--random N] [--seeds 0,1,2]
                       [--no-walkthrough] [--unpatched]

Needs the venv made by ../shared/anchors/install.sh alfworld (re-runs itself there).
"""
import argparse
import json
import os
import random
import sys


def reexec_in_anchor_venv():
    venv = os.environ.get("ANCHOR_ALFWORLD_VENV", os.path.expanduser("~/.cache/nsea-anchors/venv-alfworld"))
    py = os.path.join(venv, "bin", "python")
    if os.path.exists(py) and os.path.realpath(sys.prefix) != os.path.realpath(venv):
        os.execv(py, [py] + sys.argv)
    print("engine not installed: run install.sh alfworld", file=sys.stderr)
    sys.exit(2)


def memoize_parsers():
    """Cache TextWorld's two TatSu parse-and-convert functions (string -> fresh object tree).

    They are pure functions of their arguments, and they are most of a step's time: the
    engine re-parses every command template and every grammar condition at every step. Each
    call still gets its own deep copy, since the engine mutates what they return (it sets a
    symbol's context). The traces stay byte-identical to alfworld_trace.py's (checked by
    `--check-against-unpatched`, and by CI's live-engine test, which runs the unpatched engine).
    """
    import copy
    import textworld.logic as tw_logic
    import textworld.envs.pddl.textgen as tw_textgen

    def cached(function):
        memo = {}

        def wrapper(*args, **kwargs):
            key = (args, tuple(sorted(kwargs.items())))
            if key not in memo:
                memo[key] = function(*args, **kwargs)
            return copy.deepcopy(memo[key])
        return wrapper

    tw_logic._parse_and_convert = cached(tw_logic._parse_and_convert)
    tw_textgen._parse_and_convert = cached(tw_textgen._parse_and_convert)
    # The PDDL -> SAS translation (twice per reset: TextWorld reloads the game at every reset)
    # is a pure function of the domain and problem texts too.
    import fast_downward
    fast_downward.pddl2sas = cached(fast_downward.pddl2sas)


def make_env(path):
    """The game at `path` as ALFWorld's evaluation loads it (AlfredTWEnv.init_env): won and the
    admissible commands requested, the wrappers AlfredDemangler(shuffle=False) and AlfredInfos,
    batch size 1, no step limit."""
    import textworld
    import textworld.gym
    from alfworld.agents.environment.alfred_tw_env import AlfredDemangler, AlfredInfos
    infos_wanted = textworld.EnvInfos(won=True, admissible_commands=True, extras=["gamefile"])
    env_id = textworld.gym.register_games([os.path.abspath(path)], infos_wanted, batch_size=1,
                                          asynchronous=False, max_episode_steps=None,
                                          wrappers=[AlfredDemangler(shuffle=False), AlfredInfos])
    return textworld.gym.make(env_id)


def trace(env, plan, n_random, seed):
    """alfworld_trace.py's main loop, yielding its dicts."""
    obs, infos = env.reset()
    won = bool(infos["won"][0])
    yield {"step": 0, "observation": obs[0], "admissible": list(infos["admissible_commands"][0]), "won": won}
    rng = random.Random(seed)
    steps = n_random if n_random is not None else len(plan)
    for k in range(1, steps + 1):
        if won:
            break
        cmd = rng.choice(sorted(infos["admissible_commands"][0])) if n_random is not None else plan[k - 1]
        obs, _scores, _dones, infos = env.step([cmd])
        won = bool(infos["won"][0])
        yield {"step": k, "command": cmd, "observation": obs[0],
               "admissible": list(infos["admissible_commands"][0]), "won": won}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("root")
    ap.add_argument("out")
    ap.add_argument("games", nargs="+")
    ap.add_argument("--random", type=int, default=30)
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--unpatched", action="store_true", help="do not cache the engine's parsers")
    ap.add_argument("--no-walkthrough", action="store_true", help="record the random walks only")
    args = ap.parse_args()
    try:
        import textworld
        import textworld.gym
        from alfworld.agents.environment.alfred_tw_env import AlfredDemangler, AlfredInfos
    except ImportError:
        reexec_in_anchor_venv()
    if not args.unpatched:
        memoize_parsers()
    seeds = [int(s) for s in args.seeds.split(",") if s]
    with open(args.out, "a", encoding="utf-8") as out:
        for game_dir in args.games:
            path = os.path.join(game_dir, "game.tw-pddl") if os.path.isdir(game_dir) else game_dir
            game = json.load(open(path, encoding="utf-8"))
            rel = os.path.relpath(os.path.dirname(os.path.abspath(path)), os.path.abspath(args.root))
            env = make_env(path)
            runs = [] if args.no_walkthrough else [("walkthrough", list(game.get("walkthrough") or []), None, 0)]
            runs += [(f"random-{args.random}-seed-{s}", None, args.random, s) for s in seeds]
            lines = []
            for name, plan, n, seed in runs:
                for row in trace(env, plan, n, seed):
                    lines.append(json.dumps({"game": rel, "trace": name, **row}))
            env.close()
            # One game's traces are written whole, so an interrupted recording resumes by game.
            out.write("\n".join(lines) + "\n")
            out.flush()


if __name__ == "__main__":
    main()
