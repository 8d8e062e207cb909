"""Writes the FK test vectors core/tests/pinocchio_fk.rs checks the generated models against:
for 1,000 random configurations within the joint limits, the tool frame's pose computed by
Pinocchio from the URDF.

    python3 -m venv /tmp/pin && /tmp/pin/bin/pip install -r core/tests/pinocchio/requirements.txt
    /tmp/pin/bin/python core/tests/pinocchio/make_vectors.py

The Panda is read from example-robot-data's own file (its panda.urdf in the pip package), so
the vectors also check that robots/franka_panda/ is that robot; the Gen3 from
robots/kinova_gen3/gen3.urdf (Kinova's file).
"""

import importlib.metadata
import pathlib

import numpy as np
import pinocchio as pin

HERE = pathlib.Path(__file__).resolve().parent
ROBOTS = HERE.parents[2] / "robots"
COUNT = 1000


def example_robot_data(path):
    for f in importlib.metadata.files("example-robot-data"):
        if str(f).endswith(path):
            return pathlib.Path(f.locate())
    raise SystemExit(f"example-robot-data has no {path}")


# name, URDF, joints in chain order, tool frame, seed
MODELS = [
    (
        "franka_panda",
        example_robot_data("robots/panda_description/urdf/panda.urdf"),
        [f"panda_joint{i}" for i in range(1, 8)],
        "panda_hand_tcp",
        24,
    ),
    (
        "kinova_gen3",
        ROBOTS / "kinova_gen3" / "gen3.urdf",
        [f"joint_{i}" for i in range(1, 8)],
        "end_effector_link",
        25,
    ),
]


def write(name, urdf, joints, tool, seed):
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    frame = model.getFrameId(tool)
    assert frame < len(model.frames), f"{urdf} has no frame {tool}"
    ids = [model.getJointId(j) for j in joints]
    rng = np.random.default_rng(seed)
    lines = [
        f"# {name}: Pinocchio {pin.__version__} FK of frame {tool} from {urdf.name}",
        f"# made by core/tests/pinocchio/make_vectors.py (seed {seed}); per line: "
        f"{len(joints)} joint values, then the tool pose's rotation (row-major) and translation",
    ]
    for _ in range(COUNT):
        q = pin.neutral(model)
        values = []
        for jid in ids:
            joint = model.joints[jid]
            lo = model.lowerPositionLimit[joint.idx_q]
            hi = model.upperPositionLimit[joint.idx_q]
            if joint.nq == 2:  # continuous: (cos, sin)
                theta = rng.uniform(-np.pi, np.pi)
                q[joint.idx_q : joint.idx_q + 2] = [np.cos(theta), np.sin(theta)]
            else:
                theta = rng.uniform(lo, hi)
                q[joint.idx_q] = theta
            values.append(theta)
        pin.framesForwardKinematics(model, data, q)
        pose = data.oMf[frame]
        numbers = values + list(pose.rotation.flatten()) + list(pose.translation)
        lines.append(" ".join(repr(float(v)) for v in numbers))
    out = HERE / f"{name}.txt"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out} ({COUNT} configurations)")


for m in MODELS:
    write(*m)
