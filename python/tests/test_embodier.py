"""The online API: an Embodier run over several chunks keeps its assignment and continuity."""

import copy

import numpy as np
import pytest

import omcbsa


def hand_array(problem_dict):
    """(hands, H, 7): the problem's trajectories as position + quaternion xyzw."""
    return np.array([[p["position"] + p["quat_xyzw"] for p in t["poses"]]
                     for t in problem_dict["trajectories"]])


@pytest.fixture
def setup(two_hand_problem):
    """The two-hand problem with every arm standing where a whole plan starts."""
    problem = omcbsa.Problem(two_hand_problem)
    start = omcbsa.plan(problem).joint_paths[:, 0]
    d = copy.deepcopy(two_hand_problem)
    for r, q in zip(d["robots"], start):
        r["initial"] = q.tolist()
    return d


def test_chunks_keep_the_assignment_and_the_whole_run_validates(setup):
    hands = hand_array(setup)  # (2, 25, 7)
    h = hands.shape[1]
    emb = omcbsa.Embodier(omcbsa.Problem(setup))
    assert emb.assignment is None
    # Chunks of 8 poses, each replacing the tail of the one before (overlap 4).
    starts = [0, 4, 8, 12, 17]
    timeline = None
    assignment = None
    for s in starts:
        segment = emb.push_chunk(s, hands[:, s:s + 8])
        assert segment.dtype == np.float64 and segment.shape[0] == 2 and segment.shape[2] == 7
        index = emb.timeline_index(s)
        assert index == emb.last_index
        if timeline is None:
            assignment = emb.assignment
            assert sorted(assignment) == [0, 1]
            timeline = emb.planned(0)
            assert np.array_equal(timeline[:, 0], np.array([r["initial"] for r in setup["robots"]]))
            assert np.array_equal(timeline[:, 1:1 + emb.approach_len], emb.approach)
        else:
            assert emb.assignment == assignment
            # The new segment continues the plan kept before it.
            timeline = np.concatenate([timeline[:, :index], segment], axis=1)
        assert np.array_equal(timeline, emb.planned(0))
    first = emb.timeline_index(0)
    assert emb.end - first == h
    # The run from the first chunk's first pose is a whole solution of the problem:
    # tracking, velocity (continuity at every junction), limits and collisions all hold.
    solution = omcbsa.Solution({
        "format": "omcbsa.solution.v1", "problem": setup["name"], "planner": "omcbsa",
        "status": "solved", "planning_time_s": 0.0, "assignment": assignment,
        "joint_paths": timeline[:, first:].tolist(),
    })
    report = omcbsa.validate(omcbsa.Problem(setup), solution)
    assert report.valid, [str(v) for v in report.violations]
    # So is the approach from initial: consecutive configurations within the velocity limit
    # (Gen3: 1.3963 rad/s for joints 1-4, 1.2218 rad/s for joints 5-7).
    vmax = np.array([1.3963] * 4 + [1.2218] * 3) * setup["dt"]
    assert (np.abs(np.diff(timeline[:, :first + 1], axis=1)) <= vmax + 1e-6).all()


def test_unreachable_chunk_raises_and_keeps_the_plan(setup):
    hands = hand_array(setup)
    emb = omcbsa.Embodier(omcbsa.Problem(setup))
    emb.push_chunk(0, hands[:, :8])
    before = emb.planned(0)
    far = hands[:, 4:12].copy()
    far[1, 3, :3] = [5.0, 5.0, 5.0]
    with pytest.raises(omcbsa.ChunkError) as e:
        emb.push_chunk(4, far)
    assert e.value.kind == "unreachable" and e.value.hand == 1 and e.value.step == 7
    assert "hand 1" in str(e.value) and "step 7" in str(e.value)
    assert np.array_equal(emb.planned(0), before)


def test_bad_chunks_raise_value_error_naming_the_field(setup):
    hands = hand_array(setup)
    emb = omcbsa.Embodier(omcbsa.Problem(setup))
    with pytest.raises(ValueError, match=r"hands: expected an array of shape \(hands, H, 7\)"):
        emb.push_chunk(0, hands[0])
    bad = hands[:, :8].copy()
    bad[1, 4, 3:] = [0, 0, 0, 2]
    with pytest.raises(ValueError, match=r"hands\[1\]\[4\]\.quat_xyzw: norm 2"):
        emb.push_chunk(0, bad)
    no_initial = copy.deepcopy(setup)
    del no_initial["robots"][1]["initial"]
    with pytest.raises(ValueError, match=r"robots\[1\]\.initial: missing"):
        omcbsa.Embodier(omcbsa.Problem(no_initial))
