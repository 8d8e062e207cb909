"""fk and ik vectorised over leading dimensions, equal to one-by-one calls and to the CLI."""

import json

import numpy as np
import pytest

import omcbsa

M = "kinova_gen3"
# Joint limits of Kinova's Gen3 (continuous joints sampled over one turn).
LOWER = np.array([-np.pi, -2.24, -np.pi, -2.57, -np.pi, -2.09, -np.pi])
UPPER = -LOWER


def random_q(rng, shape):
    return rng.uniform(LOWER, UPPER, size=(*shape, 7))


def test_vectorised_fk_equals_one_by_one():
    q = random_q(np.random.default_rng(1), (4, 5))
    poses = omcbsa.fk(M, q)
    assert poses.shape == (4, 5, 7) and poses.dtype == np.float64
    for i in range(4):
        for j in range(5):
            assert np.array_equal(poses[i, j], omcbsa.fk(M, q[i, j]))
    assert np.array_equal(omcbsa.fk(M, q.reshape(-1, 7)).reshape(4, 5, 7), poses)
    assert np.allclose(np.linalg.norm(poses[..., 3:], axis=-1), 1.0)
    assert (poses[..., 6] >= 0).all()


def test_fk_equals_the_cli(cli, omcbsa_bin):
    q = random_q(np.random.default_rng(2), (6,))
    code, out, err = cli(omcbsa_bin, "fk", "--model", M,
                         stdin="".join(json.dumps(list(r)) + "\n" for r in q))
    assert code == 0, err
    want = np.array([json.loads(l)["position"] + json.loads(l)["quat_xyzw"]
                     for l in out.splitlines()])
    assert np.array_equal(omcbsa.fk(M, q), want)


def test_vectorised_ik_equals_one_by_one_and_reaches_the_poses():
    rng = np.random.default_rng(3)
    q = random_q(rng, (3, 4))
    poses = omcbsa.fk(M, q)
    seeds = np.clip(q + rng.normal(0, 0.05, q.shape), LOWER, UPPER)
    sol, ok = omcbsa.ik(M, poses, seeds)
    assert sol.shape == (3, 4, 7) and sol.dtype == np.float64
    assert ok.shape == (3, 4) and ok.dtype == np.bool_
    assert ok.all()
    for i in range(3):
        for j in range(4):
            one, one_ok = omcbsa.ik(M, poses[i, j], seeds[i, j])
            assert one_ok and np.array_equal(one, sol[i, j])
    reached = omcbsa.fk(M, sol)
    assert np.abs(reached[..., :3] - poses[..., :3]).max() < 1e-5


def test_ik_without_seeds_equals_the_cli(cli, omcbsa_bin):
    poses = omcbsa.fk(M, random_q(np.random.default_rng(4), (3,)))
    sol, ok = omcbsa.ik(M, poses, seed=7)
    lines = "".join(json.dumps({"position": list(p[:3]), "quat_xyzw": list(p[3:])}) + "\n"
                    for p in poses)
    code, out, err = cli(omcbsa_bin, "ik", "--model", M, "--seed", "7", stdin=lines)
    assert code == 0, err
    assert ok.all()
    assert np.array_equal(sol, np.array([json.loads(l) for l in out.splitlines()]))


def test_unreachable_pose_is_nan_and_not_ok():
    far = np.array([[5.0, 0, 0, 0, 0, 0, 1], [0.3, 0.0, 0.5, 1, 0, 0, 0]])
    sol, ok = omcbsa.ik(M, far)
    assert ok.tolist() == [False, True]
    assert np.isnan(sol[0]).all() and np.isfinite(sol[1]).all()


# Franka's published position limits of the Panda.
PANDA_LOWER = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
PANDA_UPPER = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])


@pytest.mark.parametrize("name", ["franka_panda", "panda"])
def test_panda_fk_and_ik_by_name_and_alias(name, cli, omcbsa_bin):
    q = np.random.default_rng(7).uniform(PANDA_LOWER, PANDA_UPPER, size=(5, 7))
    poses = omcbsa.fk(name, q)
    code, out, err = cli(omcbsa_bin, "fk", "--model", "franka_panda",
                         stdin="".join(json.dumps(list(r)) + "\n" for r in q))
    assert code == 0, err
    want = np.array([json.loads(l)["position"] + json.loads(l)["quat_xyzw"]
                     for l in out.splitlines()])
    assert np.array_equal(poses, want)
    # The name picks the model: these joint values are outside the Gen3's joint 6 limits.
    with pytest.raises(omcbsa.InputError, match="joint_6"):
        omcbsa.fk("kinova_gen3", q)
    sol, ok = omcbsa.ik(name, poses, seeds=q)
    assert ok.all()
    assert np.allclose(omcbsa.fk(name, sol)[:, :3], poses[:, :3], atol=1e-5)
