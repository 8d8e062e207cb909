#!/usr/bin/env python3
"""Records ALOHA's scripted bimanual tasks in simulation as hand trajectories: the `aloha-sim`
family of `omcbsa bench-online` (data/aloha_sim/, described in its README.md).

The scripted policies reimplement ACT's published ones, `PickAndTransferPolicy` and
`InsertionPolicy` in `scripted_policy.py` of https://github.com/tonyzhaozh/act (Zhao et al.,
"Learning Fine-Grained Bimanual Manipulation with Low-Cost Hardware", RSS 2023): the same
waypoints and timings, open loop from the first observation, without the optional noise.

The simulation is gym-aloha 0.1.5's: its MJCF and its end-effector tasks
(`gym_aloha.tasks.sim_end_effector`), where a mocap body welded to each gripper is moved by
the policy. `gym_aloha.env.AlohaEnv` refuses those tasks, so dm_control's
`control.Environment` is built here from the physics and the task, as ACT's `ee_sim_env.py`
does. The tasks draw their objects' poses unseeded; here the episode's seed is passed to
`sample_box_pose` / `sample_insertion_pose`, as gym-aloha's environments do on `reset(seed)`.

The simulation first settles for `SETTLE_STEPS` with the mocaps held where the reset put them
(see there why); the policy's waypoints are read from the reset's observation, as ACT's are.
Recorded per step (401: where the hands are when the policy starts, then after each of its 400
steps at 50 Hz) and per hand:
the pose the gripper reached, the frame the mocap drives (gripper_link's pose composed with
the inverse of the weld's offset), not the mocap command. Also recorded per episode, for
information only: the task's reward (success = the task's maximum reward reached) and how far
the reached poses were from the commands. Every seed of the range is written, failed episodes
too. Nothing is rendered.

Run in the venv of setup.sh (MuJoCo 2.3.7 and dm-control 1.0.14, ACT's versions):
    .venv-aloha/bin/python scripts/aloha/record.py --out data/aloha_sim
"""

import argparse
import functools
import gzip
import json
import math
import os
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from unittest import mock

# Nothing is rendered: no OpenGL context is needed or made.
os.environ.setdefault("MUJOCO_GL", "disable")

import numpy as np  # noqa: E402
from dm_control import mujoco  # noqa: E402
from dm_control.rl import control  # noqa: E402
from gym_aloha import utils as aloha_utils  # noqa: E402
from gym_aloha.constants import ASSETS_DIR, DT  # noqa: E402
from gym_aloha.tasks import sim_end_effector as ee  # noqa: E402

EPISODE_FORMAT = "omcbsa-aloha-episode/1"
INDEX_FORMAT = "omcbsa-aloha-sim/1"
# ACT's episode length for both scripted tasks (constants.SIM_TASK_CONFIGS).
POLICY_STEPS = 400
# Steps the simulation runs, the mocaps held where the reset put them, before the policy's
# first step. The reset places each mocap at gripper_link's pose, but under MuJoCo 2.3.7 the
# weld holds gripper_link 0.1347 m behind its mocap (the offset MuJoCo computes from the
# model's reference pose): left alone, the arms lurch 0.13 m in the policy's first 4 steps
# (up to 2 m/s) before any motion of the policy. After 50 steps (1 s) the hands are within
# 4 mm of the mocaps and creep on at under 0.2 mm per step.
SETTLE_STEPS = 50
DIGITS = 6
HANDS = ("left", "right")
PACKAGES = ("gym-aloha", "mujoco", "dm-control", "numpy")


# --- quaternions, MuJoCo's order (w, x, y, z) --------------------------------------------


def quat_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def quat_conj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def quat_about(axis, degrees):
    """The rotation by `degrees` about the unit vector `axis`."""
    half = math.radians(degrees) / 2.0
    return np.concatenate([[math.cos(half)], math.sin(half) * np.asarray(axis, float)])


def rotate(q, v):
    return quat_mul(quat_mul(q, np.concatenate([[0.0], v])), quat_conj(q))[1:]


# --- the scripted policies ----------------------------------------------------------------


class Waypoint:
    """A hand's target at policy step `t`: position, orientation (w, x, y, z), gripper
    opening (0 closed, 1 open)."""

    def __init__(self, t, xyz, quat, grip):
        self.t = t
        self.xyz = np.asarray(xyz, float)
        self.quat = np.asarray(quat, float)
        self.grip = float(grip)


def command(waypoints, step):
    """The hand's command at `step`: linear between the waypoints around it (orientation by
    normalised linear interpolation, as the mocap normalises what it is given)."""
    for a, b in zip(waypoints, waypoints[1:]):
        if a.t <= step < b.t:
            s = (step - a.t) / (b.t - a.t)
            quat = a.quat + s * (b.quat - a.quat)
            return a.xyz + s * (b.xyz - a.xyz), quat / np.linalg.norm(quat), a.grip + s * (b.grip - a.grip)
    raise ValueError(f"step {step} is outside the waypoints' {waypoints[0].t}..{waypoints[-1].t}")


def transfer_waypoints(start_left, start_right, box):
    """Transfer cube: the right hand picks the cube (tilted 60 degrees down), carries it to a
    meeting point in the middle; the left hand, turned 90 degrees about its fingers, comes
    from its side, closes on the cube, and the right hand lets go and backs off."""
    (left_xyz, left_quat), (right_xyz, right_quat) = start_left, start_right
    pick = quat_mul(right_quat, quat_about([0, 1, 0], -60))
    meet_left = quat_about([1, 0, 0], 90)
    meet = np.array([0.0, 0.5, 0.25])
    left = [
        Waypoint(0, left_xyz, left_quat, 0),
        Waypoint(100, meet + [-0.1, 0, -0.02], meet_left, 1),
        Waypoint(260, meet + [0.02, 0, -0.02], meet_left, 1),
        Waypoint(310, meet + [0.02, 0, -0.02], meet_left, 0),
        Waypoint(360, meet + [-0.1, 0, -0.02], [1, 0, 0, 0], 0),
        Waypoint(400, meet + [-0.1, 0, -0.02], [1, 0, 0, 0], 0),
    ]
    right = [
        Waypoint(0, right_xyz, right_quat, 0),
        Waypoint(90, box + [0, 0, 0.08], pick, 1),
        Waypoint(130, box + [0, 0, -0.015], pick, 1),
        Waypoint(170, box + [0, 0, -0.015], pick, 0),
        Waypoint(200, meet + [0.05, 0, 0], pick, 0),
        Waypoint(220, meet, pick, 0),
        Waypoint(310, meet, pick, 1),
        Waypoint(360, meet + [0.1, 0, 0], pick, 1),
        Waypoint(400, meet + [0.1, 0, 0], pick, 1),
    ]
    return left, right


def insertion_waypoints(start_left, start_right, peg, socket):
    """Insertion: the left hand picks the socket, the right hand the peg (both tilted 60
    degrees down, towards the other arm); both lift them to a meeting point and the peg's
    hand pushes the peg into the socket."""
    (left_xyz, left_quat), (right_xyz, right_quat) = start_left, start_right
    # Both from the right hand's start orientation, as the published policy has it.
    pick_right = quat_mul(right_quat, quat_about([0, 1, 0], -60))
    pick_left = quat_mul(right_quat, quat_about([0, 1, 0], 60))
    meet = np.array([0.0, 0.5, 0.15])
    lift_right = 0.00715

    def hand(start_xyz, start_quat, obj, quat, approach, insert):
        return [
            Waypoint(0, start_xyz, start_quat, 0),
            Waypoint(120, obj + [0, 0, 0.08], quat, 1),
            Waypoint(170, obj + [0, 0, -0.03], quat, 1),
            Waypoint(220, obj + [0, 0, -0.03], quat, 0),
            Waypoint(285, meet + approach, quat, 0),
            Waypoint(340, meet + insert, quat, 0),
            Waypoint(400, meet + insert, quat, 0),
        ]

    left = hand(left_xyz, left_quat, socket, pick_left, [-0.1, 0, 0], [-0.05, 0, 0])
    right = hand(
        right_xyz, right_quat, peg, pick_right, [0.1, 0, lift_right], [0.05, 0, lift_right]
    )
    return left, right


# --- the simulation -----------------------------------------------------------------------


class Unrendered:
    """An end-effector task whose observation is what the policy and the recorder read,
    without the camera images."""

    def get_observation(self, physics):
        return {
            "env_state": self.get_env_state(physics),
            "mocap_pose_left": np.concatenate(
                [physics.data.mocap_pos[0], physics.data.mocap_quat[0]]
            ).copy(),
            "mocap_pose_right": np.concatenate(
                [physics.data.mocap_pos[1], physics.data.mocap_quat[1]]
            ).copy(),
        }


class TransferTask(Unrendered, ee.TransferCubeEndEffectorTask):
    pass


class InsertionTask(Unrendered, ee.InsertionEndEffectorTask):
    pass


TASKS = {
    # name: (MJCF, task class, the sampler the task calls)
    "transfer": (
        "bimanual_viperx_end_effector_transfer_cube.xml",
        TransferTask,
        "sample_box_pose",
    ),
    "insertion": (
        "bimanual_viperx_end_effector_insertion.xml",
        InsertionTask,
        "sample_insertion_pose",
    ),
}


def make_env(task_name, seed):
    """dm_control's environment of a task, as ACT's `make_ee_sim_env` builds it (no time limit
    here: the recorder stops after the policy's steps)."""
    xml, task_class, _ = TASKS[task_name]
    physics = mujoco.Physics.from_xml_path(str(ASSETS_DIR / xml))
    task = task_class(random=seed)
    return control.Environment(
        physics,
        task,
        time_limit=float("inf"),
        control_timestep=DT,
        n_sub_steps=None,
        flat_observation=False,
    )


def reset_seeded(env, task_name, seed):
    """`env.reset()` with the episode's seed passed to the task's object sampler."""
    sampler = TASKS[task_name][2]
    seeded = functools.partial(getattr(aloha_utils, sampler), seed)
    with mock.patch.object(ee, sampler, seeded):
        return env.reset()


class Weld:
    """The frame a mocap body drives through its weld to a body: the weld holds
    `body = mocap * offset` (MuJoCo's relpose, computed from the model's reference pose when
    the MJCF gives none, with the anchor at the body's origin)."""

    def __init__(self, physics, body):
        model = physics.model
        weld = mujoco.wrapper.mjbindings.enums.mjtEq.mjEQ_WELD
        body_id = model.name2id(body, "body")
        rows = [
            i for i in range(model.neq) if model.eq_type[i] == weld and model.eq_obj2id[i] == body_id
        ]
        if len(rows) != 1:
            raise RuntimeError(f"{body}: expected one weld to a mocap body, found {len(rows)}")
        data = model.eq_data[rows[0]]
        if np.any(data[0:3] != 0.0):
            raise RuntimeError(f"{body}: the weld's anchor is not the body's origin: {data[0:3]}")
        self.body = body
        self.offset_pos = data[3:6].copy()
        self.offset_quat = data[6:10] / np.linalg.norm(data[6:10])

    def reached(self, physics):
        """The driven frame where the body is now: position, quaternion (w, x, y, z)."""
        pos = physics.named.data.xpos[self.body]
        quat = physics.named.data.xquat[self.body]
        frame_quat = quat_mul(quat, quat_conj(self.offset_quat))
        return pos - rotate(frame_quat, self.offset_pos), frame_quat

    def axis(self, gripper_axis):
        """A gripper_link axis in the driven frame."""
        return rotate(self.offset_quat, np.asarray(gripper_axis, float))


def rounded_pose(pos, quat_wxyz):
    """A pose as the project writes them: position, quaternion in ROS order (x, y, z, w), to
    1e-6; the quaternion's largest component is then set from the others so that the norm
    stays within 5e-7 of 1."""
    q = np.array([quat_wxyz[1], quat_wxyz[2], quat_wxyz[3], quat_wxyz[0]])
    q = q if q[3] >= 0.0 else -q
    r = np.round(q, DIGITS)
    big = int(np.argmax(np.abs(q)))
    rest = sum(r[i] ** 2 for i in range(4) if i != big)
    r[big] = round(math.copysign(math.sqrt(max(0.0, 1.0 - rest)), q[big]), DIGITS)
    if abs(float(np.linalg.norm(r)) - 1.0) > 5e-7:
        raise RuntimeError(f"quaternion {q} does not round to a unit one")
    return {"position": [clean(x) for x in pos], "quat_xyzw": [clean(x) for x in r]}


def clean(x):
    x = round(float(x), DIGITS)
    return 0.0 if x == 0.0 else x  # no "-0.0"


def record_episode(task_name, seed):
    env = make_env(task_name, seed)
    ts = reset_seeded(env, task_name, seed)
    physics = env.physics
    welds = [Weld(physics, f"vx300s_{h}/gripper_link") for h in HANDS]
    obs = ts.observation
    hold = np.concatenate([np.concatenate([obs[f"mocap_pose_{h}"], [0.0]]) for h in HANDS])
    for _ in range(SETTLE_STEPS):
        env.step(hold)
    starts = [
        (obs[f"mocap_pose_{h}"][:3], obs[f"mocap_pose_{h}"][3:]) for h in HANDS
    ]
    state = np.asarray(obs["env_state"])
    if task_name == "transfer":
        plan = transfer_waypoints(*starts, box=state[:3])
    else:
        plan = insertion_waypoints(*starts, peg=state[:3], socket=state[7:10])
    poses = [[w.reached(physics)] for w in welds]
    rewards = []
    worst = 0.0
    for step in range(POLICY_STEPS):
        commands = [command(waypoints, step) for waypoints in plan]
        action = np.concatenate([np.concatenate([xyz, quat, [grip]]) for xyz, quat, grip in commands])
        ts = env.step(action)
        rewards.append(float(ts.reward))
        for hand, weld in enumerate(welds):
            pos, quat = weld.reached(physics)
            poses[hand].append((pos, quat))
            worst = max(worst, float(np.linalg.norm(pos - physics.data.mocap_pos[hand])))
    max_reward = max(rewards)
    return {
        "format": EPISODE_FORMAT,
        "task": task_name,
        "seed": seed,
        "dt": DT,
        "success": max_reward == env.task.max_reward,
        "max_reward": max_reward,
        "task_max_reward": env.task.max_reward,
        "max_position_error_m": clean(worst),
        "hands": [
            {"name": h, "poses": [rounded_pose(p, q) for p, q in hand_poses]}
            for h, hand_poses in zip(HANDS, poses)
        ],
    }, welds


def one_per_line(obj, key, item_lines):
    """`obj` as JSON, its fields one per line; the items of the list under `key` as
    `item_lines` gives them."""
    fields = [f"  {json.dumps(k)}: {json.dumps(v)}" for k, v in obj.items() if k != key]
    items = ",\n".join(item_lines(obj[key]))
    return "{\n" + ",\n".join(fields + [f'  {json.dumps(key)}: [\n{items}\n  ]']) + "\n}\n"


def compact(x):
    return json.dumps(x, separators=(",", ":"))


def hand_lines(hands):
    for hand in hands:
        poses = ",\n".join(f"      {compact(p)}" for p in hand["poses"])
        yield f'    {{"name": {json.dumps(hand["name"])}, "poses": [\n{poses}\n    ]}}'


def write_episode(path, episode):
    """Gzipped JSON, one pose per line (no time stamp in the gzip header: the same episode
    gives the same bytes)."""
    text = one_per_line(episode, "hands", hand_lines)
    with open(path, "wb") as raw, gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0) as f:
        f.write(text.encode())


def recorder_commit():
    """The commit of this script, and whether its folder differs from that commit."""
    here = Path(__file__).resolve().parent
    git = ["git", "-C", str(here)]
    commit = subprocess.run(git + ["rev-parse", "HEAD"], capture_output=True, text=True, check=True)
    status = subprocess.run(
        git + ["status", "--porcelain", "--", "."], capture_output=True, text=True, check=True
    )
    return commit.stdout.strip(), bool(status.stdout.strip())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="output directory (its index and episode files are replaced)")
    parser.add_argument("--first-seed", type=int, default=100)
    parser.add_argument("--episodes", type=int, default=50, help="episodes per task")
    parser.add_argument("--tasks", default="transfer,insertion")
    args = parser.parse_args()
    tasks = args.tasks.split(",")
    unknown = [t for t in tasks if t not in TASKS]
    if unknown or args.episodes < 1:
        parser.error(f"tasks are {', '.join(TASKS)}; --episodes at least 1")
    commit, dirty = recorder_commit()
    if dirty:
        print("warning: scripts/aloha differs from HEAD: the index names HEAD, marked dirty", file=sys.stderr)
    args.out.mkdir(parents=True, exist_ok=True)
    # The index lists exactly the episodes in the directory: earlier ones go.
    for old in [*args.out.glob("*.json.gz"), *args.out.glob("index.json")]:
        old.unlink()
    entries = []
    welds = None
    for task_name in tasks:
        for seed in range(args.first_seed, args.first_seed + args.episodes):
            episode, welds = record_episode(task_name, seed)
            name = f"{task_name}_{seed}.json.gz"
            write_episode(args.out / name, episode)
            entries.append(
                {
                    "file": name,
                    "task": task_name,
                    "seed": seed,
                    "success": episode["success"],
                    "max_reward": episode["max_reward"],
                    "max_position_error_m": episode["max_position_error_m"],
                }
            )
            print(f"{name}: success {episode['success']} (reward {episode['max_reward']:g})", file=sys.stderr)
    index = {
        "format": INDEX_FORMAT,
        "dt": DT,
        "steps": POLICY_STEPS + 1,
        "recorder": {
            "script": "scripts/aloha/record.py",
            "commit": commit,
            "dirty": dirty,
            "packages": {p: metadata.version(p) for p in PACKAGES},
        },
        "hands": [
            {
                "name": h,
                "weld_offset": {
                    "position": [clean(x) for x in w.offset_pos],
                    "quat_wxyz": [clean(x) for x in w.offset_quat],
                },
                "finger_axis": [clean(x) for x in w.axis([1, 0, 0])],
                "closing_axis": [clean(x) for x in w.axis([0, 1, 0])],
            }
            for h, w in zip(HANDS, welds)
        ],
        "episodes": entries,
    }
    lines = one_per_line(index, "episodes", lambda es: (f"    {compact(e)}" for e in es))
    (args.out / "index.json").write_text(lines)
    done = sum(e["success"] for e in entries)
    print(f"{len(entries)} episodes, {done} successful, in {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
