"""Mixed fleets from Python (issue 24): fk of the Panda by name, Problem.from_arrays and the
Embodier with one model per robot, planned and validated."""

import numpy as np
import pytest

import omcbsa

# A clear posture of each model: the Gen3's elbow bent, the Panda at Franka's "ready" pose.
HOME = {
    "kinova_gen3": np.array([0.0, 0.35, 0.0, 1.8, 0.0, 1.0, 0.0]),
    "franka_panda": np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]),
}
MODELS = ["kinova_gen3", "franka_panda", "kinova_gen3", "panda"]
BASES = np.array([[1.2 * i, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] for i in range(4)])


def full(name):
    return "franka_panda" if name == "panda" else name


def motions(steps):
    """Each arm sways slowly from its model's home posture."""
    t = np.linspace(0.0, 1.0, steps)[:, None]
    return [HOME[full(m)] + 0.15 * np.sin(2.0 * t + i + np.arange(7)) for i, m in enumerate(MODELS)]


def hands(steps):
    return np.stack([omcbsa.fk(m, q, base=b) for m, q, b in zip(MODELS, motions(steps), BASES)])


def test_the_panda_answers_fk_by_its_name_and_alias_and_differs_from_the_gen3():
    q = HOME["franka_panda"]
    assert np.array_equal(omcbsa.fk("panda", q), omcbsa.fk("franka_panda", q))
    assert not np.allclose(omcbsa.fk("panda", q), omcbsa.fk("kinova_gen3", q))
    # Its own limits: joint 4 of the Panda must be negative.
    with pytest.raises(ValueError, match="panda_joint4"):
        omcbsa.fk("panda", HOME["kinova_gen3"])


def test_from_arrays_with_one_model_per_robot_is_planned_and_validated():
    problem = omcbsa.Problem.from_arrays(BASES, hands(8), 0.1, model=MODELS)
    robots = problem.to_dict()["robots"]
    assert [r["model"] for r in robots] == MODELS
    solution = omcbsa.plan(problem)
    assert solution.solved, solution.message
    assert omcbsa.validate(problem, solution).valid
    # Each robot's path reaches its own hand with its own model's kinematics.
    for i, m in enumerate(MODELS):
        reached = omcbsa.fk(m, solution.joint_paths[i], base=BASES[i])
        hand = solution.assignment[i]
        assert np.abs(reached[:, :3] - hands(8)[hand][:, :3]).max() <= 1e-3 + 1e-9


def test_a_model_list_of_the_wrong_length_is_refused():
    with pytest.raises(ValueError, match="model: 2 model names, but bases has 4 robots"):
        omcbsa.Problem.from_arrays(BASES, hands(4), 0.1, model=MODELS[:2])


def test_the_embodier_takes_one_model_per_robot():
    steps = 40
    initial = [m[0] for m in motions(steps)]
    e = omcbsa.Embodier(bases=BASES, initial=initial, dt=0.05, model=MODELS)
    timeline = e.embody(hands(steps), chunk_len=16)
    a = e.approach_len
    assert timeline.shape == (4, 1 + a + steps, 7)
    for robot, hand in enumerate(e.assignment):
        reached = omcbsa.fk(MODELS[robot], timeline[robot, 1 + a:], base=BASES[robot])
        assert np.abs(reached[:, :3] - hands(steps)[hand][:, :3]).max() <= 1e-3 + 1e-9
