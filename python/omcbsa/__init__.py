"""omcbsa: embody multi-hand manipulation policies on several Kinova Gen3 arms.

Plans which arm takes which hand and every arm's joint path (Ω-CBSA and the other planners
of the ``omcbsa`` command line), checks plans, and computes kinematics. Everything runs in
the same Rust library as the command line; bad input raises :class:`InputError` (a
``ValueError``) naming each bad field as the command line does.

>>> import omcbsa
>>> problem = omcbsa.Problem("problem.json")           # or a dict, or Problem.from_arrays
>>> solution = omcbsa.plan(problem, planner="omcbsa", timeout=5.0)
>>> solution.joint_paths.shape                        # (robots, H, 7), float64
"""

from ._omcbsa import (
    ArmFault,
    Cell,
    CellError,
    ChunkError,
    Embodier,
    InputError,
    Problem,
    Report,
    Solution,
    Stream,
    Violation,
    aloha_episode,
    fk,
    ik,
    plan,
    retime,
    validate,
)

__all__ = [
    "ArmFault",
    "Cell",
    "CellError",
    "ChunkError",
    "Embodier",
    "InputError",
    "Problem",
    "Report",
    "Solution",
    "Stream",
    "Violation",
    "aloha_episode",
    "fk",
    "ik",
    "plan",
    "retime",
    "validate",
]
