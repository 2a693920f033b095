#!/usr/bin/env python3
"""Time the real ALFWorld text engine (unpatched: TextWorld 1.7.0 + alfworld 0.4.2, loaded as
alfworld_trace.py loads it) on given games: the reset (which reloads the game, as TextWorld's
reset does) and every step of each game's walkthrough, or of a command file per game.

Usage: alfworld_time.py GAME_DIR...     prints one JSON line per game:
    {"game": DIR, "reset_s": [first, second], "steps": N, "step_s": total seconds of the N steps}
The engine is reset twice per game (the first reset also pays Python's first imports of the
game's grammar); both times are reported. Needs install.sh alfworld; re-runs itself there.
"""
import json
import os
import sys
import time


def main():
    try:
        import textworld
        import textworld.gym
        from alfworld.agents.environment.alfred_tw_env import AlfredDemangler, AlfredInfos
    except ImportError:
        venv = os.environ.get("ANCHOR_ALFWORLD_VENV", os.path.expanduser("~/.cache/nsea-anchors/venv-alfworld"))
        py = os.path.join(venv, "bin", "python")
        if os.path.exists(py) and os.path.realpath(sys.prefix) != os.path.realpath(venv):
            os.execv(py, [py] + sys.argv)
        print(json.dumps({"error": "engine not installed: run install.sh alfworld"}))
        sys.exit(2)
    for game_dir in sys.argv[1:]:
        path = os.path.join(game_dir, "game.tw-pddl")
        plan = list(json.load(open(path, encoding="utf-8")).get("walkthrough") or [])
        infos = textworld.EnvInfos(won=True, admissible_commands=True, extras=["gamefile"])
        env_id = textworld.gym.register_games([os.path.abspath(path)], infos, batch_size=1, asynchronous=False,
                                              max_episode_steps=None,
                                              wrappers=[AlfredDemangler(shuffle=False), AlfredInfos])
        env = textworld.gym.make(env_id)
        resets = []
        for _ in range(2):
            start = time.perf_counter()
            env.reset()
            resets.append(time.perf_counter() - start)
        start = time.perf_counter()
        for command in plan:
            env.step([command])
        step_s = time.perf_counter() - start
        env.close()
        print(json.dumps({"game": game_dir, "reset_s": resets, "steps": len(plan), "step_s": step_s}), flush=True)


if __name__ == "__main__":
    main()
