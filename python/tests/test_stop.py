"""The executor's stop against the reference time-optimal jerk-limited stop, Ruckig's
(``ruckig``, pinned in python/requirements.txt): from full speed (every joint at its velocity
limit, no acceleration), ``omcbsa.Stream`` (the executor's frame generator) takes at most
1.1x Ruckig's time to rest with the same limits (Ruckig's velocity interface: target velocity
0, position free)."""

import json

import numpy as np
import pytest
import ruckig

import omcbsa
from conftest import ROOT

PERIOD = 0.002  # the executor's default control period (500 Hz)


def model_limits(name):
    """(velocity, acceleration, jerk or None) of robots/<name>/model.json."""
    limits = json.loads((ROOT / "robots" / name / "model.json").read_text())["limits"]

    def values(key):
        v = limits.get(key)
        if v is None:
            return None
        return np.array(v["values"] if isinstance(v, dict) else v, dtype=float)

    return values("velocity"), values("acceleration"), values("jerk")


def ruckig_stop_time(v0, vel, acc, jerk):
    """Ruckig's time-optimal stop from `v0` (no acceleration) to rest, every joint synchronised."""
    otg = ruckig.Ruckig(len(vel))
    inp = ruckig.InputParameter(len(vel))
    inp.control_interface = ruckig.ControlInterface.Velocity
    inp.current_position = [0.0] * len(vel)
    inp.current_velocity = list(v0)
    inp.current_acceleration = [0.0] * len(vel)
    inp.target_velocity = [0.0] * len(vel)
    inp.target_acceleration = [0.0] * len(vel)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = list(vel), list(acc), list(jerk)
    trajectory = ruckig.Trajectory(len(vel))
    result = otg.calculate(inp, trajectory)
    assert result in (ruckig.Result.Working, ruckig.Result.Finished), result
    return trajectory.duration


def our_stop_time(vel, acc, jerk):
    """(stop time, speed before it): one arm along a straight joint-space line whose steps
    take every joint at its velocity limit when on time, stopping at the line's end."""
    step_time = 0.02
    line = np.arange(1, 151)[:, None] * (vel * step_time)[None, :]
    stream = omcbsa.Stream(np.zeros((1, 7)), vel[None], acc[None], jerk[None], PERIOD,
                           step_time)
    stream.push(1, line[None])
    q = stream.run(1_000_000)[:, 0, :]
    v = np.diff(q, axis=0) / PERIOD
    # the stop: from the last cycle at cruise speed (that of the line's middle) to the hold
    cruise = np.abs(v[len(v) // 2])
    at_speed = np.nonzero(np.all(np.abs(v) >= cruise * (1 - 1e-3), axis=1))[0]
    return (len(v) - 1 - at_speed[-1]) * PERIOD, cruise


@pytest.mark.parametrize("model", ["kinova_gen3", "franka_panda"])
def test_stop_from_full_speed_within_1_1x_ruckig(model):
    vel, acc, jerk = model_limits(model)
    if jerk is None:
        pytest.skip(f"robots/{model}/model.json has no jerk limit")
    ours, cruise = our_stop_time(vel, acc, jerk)
    # the cruise is at the law's share of the velocity limits: Ruckig stops from the same
    assert np.all(cruise >= 0.97 * vel), cruise / vel
    theirs = ruckig_stop_time(cruise, vel, acc, jerk)
    print(f"{model}: stop {ours:.4f} s, Ruckig {theirs:.4f} s, ratio {ours / theirs:.3f}")
    assert ours <= 1.1 * theirs, (ours, theirs)
