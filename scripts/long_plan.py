#!/usr/bin/env python3
"""Writes a valid 3-arm problem and solution of 241 steps lasting MINUTES minutes (dt =
MINUTES * 60 / 240 s), for measuring `omcbsa execute --dry-run` on long plans
(docs/EXECUTION.md): plans of different durations with the same number of waypoints.

    python3 scripts/long_plan.py OMCBSA_BINARY MINUTES OUTDIR

Each arm sways around a folded posture (well inside its limits, bases 2 m apart so the arms
never meet); its hand trajectory is the forward kinematics of that motion (`omcbsa fk`).
"""

import json
import math
import subprocess
import sys

omcbsa, minutes, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
steps = 241
dt = minutes * 60 / (steps - 1)
seed = [0.0, 0.6, 0.0, 1.8, 0.0, 0.7, math.pi / 2]
names = ["left", "middle", "right"]
bases = [-2.0, 0.0, 2.0]


def q(arm, i):
    return [s + 0.2 * math.sin(2 * math.pi * i / (60 + 7 * arm) + j) for j, s in enumerate(seed)]


paths = [[q(a, i) for i in range(steps)] for a in range(3)]
lines = "".join(json.dumps(c) + "\n" for p in paths for c in p)
poses = subprocess.run([omcbsa, "fk", "--model", "kinova_gen3"], input=lines, text=True,
                       capture_output=True, check=True).stdout.splitlines()
trajectories = []
for a in range(3):
    ps = [json.loads(line) for line in poses[a * steps:(a + 1) * steps]]
    for p in ps:
        p["position"][1] += bases[a]
    trajectories.append({"name": f"hand_{a}", "poses": ps})
problem = {
    "format": "omcbsa.problem.v1",
    "name": f"sway_{minutes}min",
    "dt": dt,
    "robots": [{"name": n, "model": "kinova_gen3",
                "base": {"position": [0.0, b, 0.0], "quat_xyzw": [0, 0, 0, 1]}}
               for n, b in zip(names, bases)],
    "trajectories": trajectories,
}
solution = {
    "format": "omcbsa.solution.v1",
    "problem": problem["name"],
    "planner": "long_plan.py",
    "status": "solved",
    "message": "",
    "planning_time_s": 0.0,
    "assignment": [0, 1, 2],
    "joint_paths": paths,
    "stats": {},
}
with open(f"{out}/problem.json", "w") as f:
    json.dump(problem, f)
with open(f"{out}/solution.json", "w") as f:
    json.dump(solution, f)
