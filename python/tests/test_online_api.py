"""The online API as a user with a policy meets it (issue 26): fk/ik with a base and a tool
centre point, a fixed or preferred assignment for plan() and the Embodier, an Embodier built
from the robots, the obstacles and dt alone, an episode longer than a problem embodied whole,
and a chunk error that names the robot, the hand and the step."""

import numpy as np
import pytest

import omcbsa

RETRACT = [0.0, -0.35, np.pi, -2.5, 0.0, -0.87, np.pi / 2]
TCP = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0, 1.0]


def quat_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def matrix(pose):
    m = np.eye(4)
    m[:3, :3] = quat_matrix(pose[3:])
    m[:3, 3] = pose[:3]
    return m


def yaw_pose(x, y, z, yaw):
    return [x, y, z, 0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)]


# Two arms facing each other across a table, 1.2 m apart.
BASES = np.array([yaw_pose(0.6, 0.0, 0.0, np.pi), yaw_pose(-0.6, 0.0, 0.0, 0.0)])


def test_fk_with_base_and_tcp_equals_composing_by_hand():
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.0, 1.0, size=(20, 7))
    base = np.array(yaw_pose(0.3, -0.2, 0.1, 0.7))
    tcp = np.array([0.01, 0.0, 0.15] + list(np.array([0.1, 0.2, 0.0, 1.0]) / np.linalg.norm([0.1, 0.2, 0.0, 1.0])))
    plain = omcbsa.fk("kinova_gen3", q)
    world = omcbsa.fk("kinova_gen3", q, base=base, tcp=tcp)
    for p, w in zip(plain, world):
        by_hand = matrix(base) @ matrix(p) @ matrix(tcp)
        assert np.allclose(matrix(w), by_hand, atol=1e-12)
    # ik with the same base and tcp finds configurations that put the tcp there.
    sol, ok = omcbsa.ik("kinova_gen3", world, seeds=q, base=base, tcp=tcp)
    assert ok.all()
    again = omcbsa.fk("kinova_gen3", sol, base=base, tcp=tcp)
    assert np.allclose(again[:, :3], world[:, :3], atol=1e-3)


def test_fk_rejects_a_base_that_is_not_a_pose():
    with pytest.raises(omcbsa.InputError, match="base"):
        omcbsa.fk("kinova_gen3", np.zeros(7), base=np.zeros(3))
    with pytest.raises(omcbsa.InputError, match="tcp"):
        omcbsa.fk("kinova_gen3", np.zeros(7), tcp=[0, 0, 0, 0, 0, 0, 2.0])


def episode(steps, rng):
    """Each arm moves smoothly and slowly from a reaching posture; the hands are where its
    tcp goes (forward kinematics), so every step can be followed."""
    t = np.linspace(0.0, 1.0, steps)[:, None]
    hands = []
    for base in BASES:
        q0 = np.array([0.0, 0.6, 0.0, 1.8, 0.0, 0.7, np.pi / 2]) + rng.uniform(-0.2, 0.2, 7)
        swing = rng.uniform(-0.25, 0.25, 7)
        q = q0 + swing * (0.5 - 0.5 * np.cos(np.pi * t))
        hands.append(omcbsa.fk("kinova_gen3", q, base=base, tcp=TCP))
    return np.stack(hands)


def test_an_episode_longer_than_a_problem_runs_through_the_embodier():
    dt = 0.02
    hands = episode(300, np.random.default_rng(5))  # 6 s at 50 Hz: more than 256 steps
    e = omcbsa.Embodier(bases=BASES, initial=[RETRACT, RETRACT], dt=dt, tcp=TCP,
                        obstacles=[{"name": "table", "shape": "box",
                                    "half_extents": [0.3, 0.4, 0.02],
                                    "pose": {"position": [0.0, 0.0, -0.05],
                                             "quat_xyzw": [0, 0, 0, 1]}}])
    timeline = e.embody(hands, chunk_len=32)
    a = e.approach_len
    assert timeline.shape == (2, 1 + a + 300, 7)
    assert np.allclose(timeline[:, 0], [RETRACT, RETRACT])
    # Every step tracked by the arm that holds the hand, within the joint speeds.
    for robot, hand in enumerate(e.assignment):
        reached = omcbsa.fk("kinova_gen3", timeline[robot, 1 + a:], base=BASES[robot], tcp=TCP)
        assert np.abs(reached[:, :3] - hands[hand][:, :3]).max() <= 1e-3 + 1e-9
    speed = np.abs(np.diff(timeline, axis=1)).max() / dt
    assert speed <= 1.3963 + 1e-9
    # The last chunk's report says how it was planned and how far behind the arms are.
    report = e.last_report
    assert report["recovery"] is None and report["blocked"] is None
    assert report["time_factor"] == 1.0
    assert report["lag_s"] == 0.0 and report["total_lag_s"] == 0.0


def test_a_fixed_assignment_is_kept_by_plan_and_by_the_embodier():
    hands = episode(20, np.random.default_rng(11))
    problem = omcbsa.Problem.from_arrays(BASES, hands, 0.05, tcp=TCP)
    free = omcbsa.plan(problem)
    assert free.solved and free.assignment == [0, 1]
    # Each hand was made by its own arm's motion; the other arm cannot follow it.
    swapped = omcbsa.plan(problem, assignment=[1, 0], timeout=2.0)
    assert swapped.status in ("no_solution", "timeout")
    preferred = omcbsa.plan(problem, assignment=[1, 0], preferred=True, timeout=2.0)
    assert preferred.solved and preferred.assignment == [0, 1]
    with pytest.raises(omcbsa.InputError, match=r"assignment\[1\]"):
        omcbsa.plan(problem, assignment=[0, 0])
    # The Embodier keeps a fixed assignment across chunks: one arm holds still.
    e = omcbsa.Embodier(bases=BASES, initial=[RETRACT, RETRACT], dt=0.05, tcp=TCP,
                        assignment=[None, 0])
    e.push_chunk(0, hands[1:, :10])
    assert e.assignment == [None, 0]
    e.commit_until(e.timeline_index(10))
    e.push_chunk(10, hands[1:, 10:])
    assert e.assignment == [None, 0]


def test_the_axis_weight_is_an_option_and_a_bad_one_is_refused():
    hands = episode(20, np.random.default_rng(11))
    for weight in (0.0, 4.0):
        e = omcbsa.Embodier(bases=BASES, initial=[RETRACT, RETRACT], dt=0.05, tcp=TCP,
                            axis_weight=weight)
        e.push_chunk(0, hands[:, :10])
        assert e.assignment == [0, 1]
    for bad in (-1.0, float("nan")):
        with pytest.raises(omcbsa.InputError, match="axis_weight"):
            omcbsa.Embodier(bases=BASES, initial=[RETRACT, RETRACT], dt=0.05, tcp=TCP,
                            axis_weight=bad)


def test_a_blocked_chunk_names_the_robot_the_hand_and_the_step():
    hands = episode(40, np.random.default_rng(13))
    # catch_up off: the chunk is an error, not reached by an approach that drops its poses.
    e = omcbsa.Embodier(bases=BASES, initial=[RETRACT, RETRACT], dt=0.05, tcp=TCP,
                        assignment=[0, 1], catch_up=False)
    e.push_chunk(0, hands[:, :20])
    # Hand 1 jumps 15 cm within one step at step 25: too fast for any joint.
    later = hands[:, 20:].copy()
    later[1, 5:, 2] += 0.15
    e.commit_until(e.timeline_index(20))
    with pytest.raises(omcbsa.ChunkError) as err:
        e.push_chunk(20, later)
    assert err.value.kind == "blocked"
    assert (err.value.robot, err.value.hand, err.value.step) == (1, 1, 25)
    assert "rad/s" in str(err.value)
    # The plan is kept: the chunk without the jump is planned.
    e.push_chunk(20, hands[:, 20:])


def test_options_are_keywords_read_by_one_helper():
    hands = episode(20, np.random.default_rng(11))
    kw = dict(bases=BASES, initial=[RETRACT, RETRACT], dt=0.05, tcp=TCP)
    # Every option a user needs, given at once.
    e = omcbsa.Embodier(**kw, planner="pp", chunk_timeout=0.5, max_chunk_len=32,
                        assignment=[0, 1], preferred=True, reassign=True, axis_weight=2.0,
                        headroom_weight=0.5, reserve_weight=0.25, time_scaling=False,
                        catch_up=False)
    e.push_chunk(0, hands[:, :10])
    r = e.last_report
    assert e.assignment == [0, 1]
    assert (r["time_factor"], r["lag_s"], r["total_lag_s"]) == (1.0, 0.0, 0.0)
    with pytest.raises(TypeError, match='unexpected keyword argument "chunk_timout"'):
        omcbsa.Embodier(**kw, chunk_timout=0.5)
    for key, bad, want in [("chunk_timeout", "1s", "a number of seconds"),
                           ("reassign", 1, "a bool"), ("catch_up", "no", "a bool"),
                           ("max_chunk_len", 2.5, "an int"),
                           ("assignment", "01", "a list of hand indices")]:
        with pytest.raises(TypeError, match=f"Embodier\\(\\): {key}: expected {want}"):
            omcbsa.Embodier(**kw, **{key: bad})
    for key in ("headroom_weight", "reserve_weight"):
        with pytest.raises(omcbsa.InputError, match=key):
            omcbsa.Embodier(**kw, **{key: -1.0})
    # Problem.from_arrays reads its options the same way.
    p = omcbsa.Problem.from_arrays(BASES, hands, 0.05, tcp=TCP, name="two", tolerance=(1e-3, 1e-2))
    assert p.name == "two"
    with pytest.raises(TypeError, match='from_arrays\\(\\) got an unexpected keyword argument "nam"'):
        omcbsa.Problem.from_arrays(BASES, hands, 0.05, nam="two")
    with pytest.raises(TypeError, match="from_arrays\\(\\): name: expected a str, got int"):
        omcbsa.Problem.from_arrays(BASES, hands, 0.05, name=2)
