"""Plans from Python equal the command line's plans on suite problems; shapes and dtypes."""

import json
import threading
import sys
import time

import numpy as np
import pytest

import omcbsa

# Long enough that no run stops at its deadline on a loaded machine: the comparison is of
# deterministic searches, not of how far each got in a time.
TIMEOUT = 60.0


@pytest.mark.parametrize("planner", ["omcbsa", "pp"])
def test_plans_equal_the_cli_on_suite_problems(suite, cli, omcbsa_bin, tmp_path, planner):
    solved = 0
    for path in suite:
        out = tmp_path / f"{path.stem}.{planner}.json"
        code, _, err = cli(omcbsa_bin, "plan", path, "-o", out, "--planner", planner,
                           "--timeout", TIMEOUT)
        assert code in (0, 1), err
        want = json.loads(out.read_text())
        got = omcbsa.plan(omcbsa.Problem(path), planner=planner, timeout=TIMEOUT)
        assert got.status == want["status"], path.name
        assert got.message == want["message"], path.name
        assert got.assignment == want["assignment"], path.name
        for key in ("expansions", "low_level_calls", "ct_nodes", "conflicts_resolved"):
            assert got.stats[key] == want["stats"][key], (path.name, key)
        if want["status"] == "solved":
            solved += 1
            # Bit for bit: the same code ran on the same input.
            assert np.array_equal(got.joint_paths, np.array(want["joint_paths"])), path.name
        else:
            assert got.joint_paths is None
    assert solved >= len(suite) // 2, f"only {solved} of {len(suite)} solved"


def test_solution_shapes_and_types(two_hand_problem):
    problem = omcbsa.Problem(two_hand_problem)
    assert (problem.robots, problem.hands, problem.horizon) == (2, 2, 25)
    s = omcbsa.plan(problem)
    assert s.status == "solved" and s.solved
    paths = s.joint_paths
    assert isinstance(paths, np.ndarray)
    assert paths.dtype == np.float64
    assert paths.shape == (2, 25, 7)
    assert sorted(s.assignment) == [0, 1]
    assert isinstance(s.stats, dict) and s.stats["expansions"] > 0
    assert s.planning_time_s > 0
    assert s.problem == problem.name and s.planner == "omcbsa"
    # The solution file round-trips through its JSON text.
    again = omcbsa.Solution.from_json(s.to_json())
    assert np.array_equal(again.joint_paths, paths)


def test_problem_from_dict_file_and_arrays_agree(two_hand_problem, tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps(two_hand_problem))
    from_file = omcbsa.Problem(path)
    from_dict = omcbsa.Problem.from_dict(two_hand_problem)
    pose = lambda p: p["position"] + p["quat_xyzw"]  # noqa: E731
    d = two_hand_problem
    from_arrays = omcbsa.Problem.from_arrays(
        np.array([pose(r["base"]) for r in d["robots"]]),
        np.array([[pose(p) for p in t["poses"]] for t in d["trajectories"]]),
        d["dt"],
        tcp=np.array([pose(r["tcp"]) for r in d["robots"]]),
        obstacles=d["obstacles"],
        tolerance=(d["tolerance"]["position_m"], d["tolerance"]["orientation_rad"]),
        name=d["name"],
    )
    assert from_file.to_dict() == from_dict.to_dict()
    a, b = omcbsa.plan(from_dict), omcbsa.plan(from_arrays)
    assert a.assignment == b.assignment
    assert np.array_equal(a.joint_paths, b.joint_paths)


def test_a_python_thread_runs_while_a_plan_is_computed(two_hand_problem):
    """With the GIL held for the whole call, the counting thread could not run at all while
    `in_plan` is set: the switch interval is raised so the interpreter never forces a switch,
    and the planning thread does nothing between setting the flag and calling plan."""
    problem = omcbsa.Problem(two_hand_problem)
    state = {"in_plan": False, "done": False, "ticks": 0}

    def planner():
        for _ in range(5):
            state["in_plan"] = True
            omcbsa.plan(problem, planner="composite-astar", timeout=0.2)
            state["in_plan"] = False
        state["done"] = True

    old = sys.getswitchinterval()
    sys.setswitchinterval(1.0)
    try:
        t = threading.Thread(target=planner)
        t.start()
        while not state["done"]:
            if state["in_plan"]:
                state["ticks"] += 1
            time.sleep(0.0005)  # lets the planning thread take the GIL back when it returns
        t.join()
    finally:
        sys.setswitchinterval(old)
    assert state["ticks"] > 10, f"the other thread ran {state['ticks']} times during planning"


def test_validate_reports_violations_in_the_cli_words(two_hand_problem, cli, omcbsa_bin, tmp_path):
    problem = omcbsa.Problem(two_hand_problem)
    good = omcbsa.plan(problem)
    report = omcbsa.validate(problem, good)
    assert report.valid and report.summary == "valid" and report.violations == []

    bad = good.to_dict()
    bad["joint_paths"][0][5][0] += 0.5  # a jump: velocity, tracking (and maybe more)
    bad = omcbsa.Solution(bad)
    report = omcbsa.validate(problem, bad)
    assert not report.valid
    rules = {v.rule for v in report.violations}
    assert {"velocity", "tracking"} <= rules

    (tmp_path / "p.json").write_text(problem.to_json())
    (tmp_path / "s.json").write_text(bad.to_json())
    code, out, err = cli(omcbsa_bin, "validate", tmp_path / "p.json", tmp_path / "s.json",
                         "--json")
    assert code == 1, err
    want = json.loads(out)
    assert report.summary == want["summary"]
    got = [(v.rule, v.robot, v.step, v.detail) for v in report.violations]
    assert got == [(v["rule"], v["robot"], v["step"], v["detail"]) for v in want["violations"]]
    code, out, _ = cli(omcbsa_bin, "validate", tmp_path / "p.json", tmp_path / "s.json")
    assert [str(v) for v in report.violations] == [l.strip() for l in out.splitlines()[1:]]
