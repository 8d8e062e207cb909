"""Bad input raises ValueError (omcbsa.InputError) naming the field, in the CLI's words."""

import copy
import json
import math

import numpy as np
import pytest

import omcbsa


def broken(problem, edit):
    p = copy.deepcopy(problem)
    edit(p)
    return p


CASES = [
    ("dt", lambda p: p.update(dt=0), "dt: must be > 0, got 0"),
    ("initial length", lambda p: p["robots"][1].update(initial=[0.0] * 6),
     "robots[1].initial: expected 7 joint values for model kinova_gen3, got 6"),
    ("initial limits", lambda p: p["robots"][0].update(initial=[0, 0, 0, 3.5, 0, 0, 0]),
     "robots[0].initial[3]: 3.5 is outside the limits [-2.57, 2.57] of joint joint_4"),
    ("quaternion", lambda p: p["trajectories"][1]["poses"][4].update(quat_xyzw=[0, 0, 0, 0.98]),
     "trajectories[1].poses[4].quat_xyzw: norm 0.98 is more than 1e-6 away from 1"),
    ("model", lambda p: p["robots"][0].update(model="ur5"),
     'robots[0].model: unknown model "ur5" (compiled in: kinova_gen3, franka_panda; aliases: panda for franka_panda)'),
    ("misspelt field", lambda p: p["robots"][0].update(initail=[0.0] * 7),
     "robots[0].initail: unknown field `initail`, expected one of `name`, `model`, `base`, "
     "`initial`, `tcp`, `tool`"),
    ("obstacle size", lambda p: p["obstacles"][0].pop("half_extents"),
     "obstacles[0].half_extents: missing (shape box needs it)"),
    ("initial collides", lambda p: p["robots"][0].update(initial=[0.0, 2.2, 0.0, 2.5, 0.0, 2.0, 0.0]),
     'robots[0].initial: robot "arm_0" cannot start here: it collides with itself'),
]


@pytest.mark.parametrize("name,edit,message", CASES, ids=[c[0] for c in CASES])
def test_bad_problem_raises_value_error_with_the_cli_words(two_hand_problem, cli, omcbsa_bin,
                                                           tmp_path, name, edit, message):
    bad = broken(two_hand_problem, edit)
    with pytest.raises(ValueError) as e:
        omcbsa.Problem(bad)
    assert isinstance(e.value, omcbsa.InputError)
    # A line of the error is the message (serde may add where in the text it stopped).
    assert any(line.startswith(message) for line in str(e.value).splitlines())
    field = message.split(":")[0]
    assert field in [f for f, _ in e.value.errors]
    # The command line says the same of the same file.
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(bad))
    code, _, err = cli(omcbsa_bin, "plan", path)
    assert code == 2
    assert message in err


def test_all_errors_of_a_problem_are_reported(two_hand_problem):
    bad = broken(two_hand_problem, lambda p: (p.update(dt=-1), p["robots"][0].update(initial=[0.0])))
    with pytest.raises(omcbsa.InputError) as e:
        omcbsa.Problem(bad)
    assert {"dt", "robots[0].initial"} <= {f for f, _ in e.value.errors}


def test_nan_in_a_dict_names_its_field(two_hand_problem):
    bad = broken(two_hand_problem,
                 lambda p: p["trajectories"][0]["poses"][3]["position"].__setitem__(1, math.nan))
    with pytest.raises(ValueError, match=r"trajectories\[0\]\.poses\[3\]\.position\[1\]: NaN is not a finite number"):
        omcbsa.Problem(bad)


def test_missing_file_names_it(tmp_path):
    with pytest.raises(ValueError, match="cannot read .*nowhere.json"):
        omcbsa.Problem(tmp_path / "nowhere.json")


def test_bad_planner_and_timeout(two_hand_problem):
    p = omcbsa.Problem(two_hand_problem)
    with pytest.raises(ValueError, match=r'planner: unknown planner "fast"'):
        omcbsa.plan(p, planner="fast")
    for t in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(ValueError, match="timeout: must be a positive number of seconds"):
            omcbsa.plan(p, timeout=t)


def test_bad_arrays_name_the_argument():
    with pytest.raises(ValueError, match=r"hands: expected a non-empty array of shape \(hands, H, 7\)"):
        omcbsa.Problem.from_arrays(np.zeros((1, 7)), np.zeros((2, 7)), 0.1)
    with pytest.raises(ValueError, match=r"hands\[0\]\[1\]\.position\[2\]: inf is not a finite number"):
        hands = np.zeros((1, 2, 7))
        hands[..., 6] = 1
        hands[0, 1, 2] = np.inf
        omcbsa.Problem.from_arrays([[0, 0, 0, 0, 0, 0, 1]], hands, 0.1)
    with pytest.raises(ValueError, match=r"q: expected an array of shape \(\.\.\., 7\), got shape \[3, 6\]"):
        omcbsa.fk("kinova_gen3", np.zeros((3, 6)))
    with pytest.raises(ValueError, match=r"q\[1\]\[2\]\[5\]: NaN is not a finite number"):
        q = np.zeros((2, 3, 7))
        q[1, 2, 5] = np.nan
        omcbsa.fk("kinova_gen3", q)
    with pytest.raises(ValueError, match=r'model: unknown model "ur5"'):
        omcbsa.fk("ur5", np.zeros(7))
    with pytest.raises(ValueError, match=r"poses\[1\]\.quat_xyzw: norm 2 is more than 1e-6 away from 1"):
        omcbsa.ik("kinova_gen3", [[0.3, 0, 0.5, 0, 0, 0, 1], [0.3, 0, 0.5, 0, 0, 0, 2]])
    with pytest.raises(ValueError, match=r"seeds: expected shape \(7,\) or the shape of poses"):
        omcbsa.ik("kinova_gen3", [[0.3, 0, 0.5, 0, 0, 0, 1]], seeds=np.zeros((2, 7)))


def test_bad_solution_names_the_field(two_hand_problem):
    s = omcbsa.plan(omcbsa.Problem(two_hand_problem)).to_dict()
    s["joint_paths"][1][2][3] = math.inf
    with pytest.raises(ValueError, match=r"joint_paths\[1\]\[2\]\[3\]: inf is not a finite number"):
        omcbsa.Solution(s)
    s = omcbsa.plan(omcbsa.Problem(two_hand_problem)).to_dict()
    del s["joint_paths"]
    with pytest.raises(ValueError, match="joint_paths: missing, but status is solved"):
        omcbsa.Solution(s)
