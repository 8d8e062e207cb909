"""Type stubs of the native module (the Rust library); see the package docstring."""

import os
from typing import Any, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Source = Union[Mapping[str, Any], str, os.PathLike[str]]

class InputError(ValueError):
    """Bad input: one line ``field: what is wrong`` per problem, as the command line says it."""

    errors: list[tuple[str, str]]
    """(field, message) pairs, e.g. ``("robots[1].initial[3]", "3.5 is outside the limits ...")``."""

class Problem:
    """A planning problem (``omcbsa.problem.v1``), checked when made.

    ``Problem(source)``: a dict in the file's layout (NumPy arrays accepted for lists) or the
    path of a problem file.
    """

    def __init__(self, source: Source) -> None: ...
    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> Problem: ...
    @staticmethod
    def from_file(path: Union[str, os.PathLike[str]]) -> Problem: ...
    @staticmethod
    def from_json(text: str) -> Problem: ...
    @staticmethod
    def from_arrays(
        bases: ArrayLike,
        hands: ArrayLike,
        dt: float,
        *,
        initial: Optional[ArrayLike] = None,
        tcp: Optional[ArrayLike] = None,
        obstacles: Optional[Sequence[Mapping[str, Any]]] = None,
        tolerance: Optional[Tuple[float, float]] = None,
        name: str = "problem",
        model: Optional[Union[str, Sequence[str]]] = None,
    ) -> Problem:
        """``bases`` (robots, 7) and ``hands`` (hands, H, 7): position + quaternion xyzw;
        ``initial`` (robots, 7) joint values; ``tcp`` (robots, 7) or (7,);
        ``tolerance`` (metres, radians)."""
    def to_dict(self) -> dict[str, Any]: ...
    def to_json(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def dt(self) -> float: ...
    @property
    def robots(self) -> int: ...
    @property
    def hands(self) -> int: ...
    @property
    def horizon(self) -> int: ...

class Solution:
    """A planner's answer (``omcbsa.solution.v1``)."""

    def __init__(self, source: Source) -> None: ...
    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> Solution: ...
    @staticmethod
    def from_file(path: Union[str, os.PathLike[str]]) -> Solution: ...
    @staticmethod
    def from_json(text: str) -> Solution: ...
    @property
    def status(self) -> str:
        """``solved``, ``no_solution``, ``timeout``, ``out_of_memory`` or ``invalid_problem``."""
    @property
    def solved(self) -> bool: ...
    @property
    def message(self) -> str: ...
    @property
    def planner(self) -> str: ...
    @property
    def problem(self) -> str: ...
    @property
    def planning_time_s(self) -> float: ...
    @property
    def assignment(self) -> list[Optional[int]]:
        """Per robot: the hand it tracks, or None when it holds."""
    @property
    def joint_paths(self) -> Optional[npt.NDArray[np.float64]]:
        """(robots, H, 7) float64, or None when not solved."""
    @property
    def stats(self) -> dict[str, Any]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def to_json(self) -> str: ...

class Violation:
    """One broken rule; ``str(v)`` is the command line's line."""

    rule: str
    robot: Optional[int]
    step: Optional[int]
    detail: str

class Report:
    """What ``validate`` found."""

    valid: bool
    summary: str
    violations: list[Violation]

def plan(
    problem: Problem,
    planner: Optional[str] = None,
    timeout: float = 5.0,
    assignment: Optional[Sequence[Optional[int]]] = None,
    preferred: bool = False,
) -> Solution:
    """Plans ``problem`` (GIL released); a plan that fails validation is never ``solved``.

    ``assignment[i]``: the hand robot i takes (None: it holds still), kept as given; with
    ``preferred=True`` only tried first, the planner choosing freely when it has no plan."""

def validate(problem: Problem, solution: Solution) -> Report:
    """Checks ``solution`` against ``problem`` as ``omcbsa validate`` does."""

def fk(
    model_name: str,
    q: ArrayLike,
    base: Optional[ArrayLike] = None,
    tcp: Optional[ArrayLike] = None,
) -> npt.NDArray[np.float64]:
    """(..., 7) joint values -> (..., 7) poses, position + quaternion xyzw (w >= 0); with
    ``base`` and ``tcp`` (7,), the tool centre point in the world: base * fk(q) * tcp."""

def ik(
    model_name: str,
    poses: ArrayLike,
    seeds: Optional[ArrayLike] = None,
    seed: int = 0,
    base: Optional[ArrayLike] = None,
    tcp: Optional[ArrayLike] = None,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
    """(..., 7) poses -> ((..., 7) joint values, NaN where none; (...) success flags); with
    ``base`` and ``tcp``, the poses are of the tool centre point in the world."""

class ChunkError(RuntimeError):
    """A chunk was not planned; the plan made before is kept."""

    kind: str
    """``unreachable``, ``blocked``, ``deadline_missed``, ``not_planned`` or ``approach``."""
    hand: Optional[int]
    step: Optional[int]
    robot: Optional[int]

class Embodier:
    """Plans policy chunks as they arrive (the library's online API).

    Built from ``bases`` (robots, 7), ``initial`` (robots, 7) and ``dt`` (with ``tcp``,
    ``obstacles``, ``tolerance`` and ``model`` as for ``Problem.from_arrays``), or from a
    Problem whose robots all give ``initial`` (its trajectories are not used). Timeline index
    0 is ``initial``, then the approach, then the chunks, one per ``dt``. ``assignment``
    (fixed, or tried first with ``preferred=True``) says which arm takes which hand;
    ``reassign=True`` lets a chunk that has no plan under the assignment take a new one from
    where the arms stand (off: a hand holding an object cannot change arms).
    ``axis_weight`` weighs the search's cost of two joint axes nearing one line, which keeps
    a chunk from leaving an arm where the next one would need a joint past its speed (0:
    chunks planned greedily, IK tracking first).
    """

    def __init__(
        self,
        setup: Optional[Problem] = None,
        *,
        bases: Optional[ArrayLike] = None,
        initial: Optional[ArrayLike] = None,
        dt: Optional[float] = None,
        tcp: Optional[ArrayLike] = None,
        obstacles: Optional[Sequence[Mapping[str, Any]]] = None,
        tolerance: Optional[Tuple[float, float]] = None,
        model: Optional[Union[str, Sequence[str]]] = None,
        planner: Optional[str] = None,
        chunk_timeout: float = 1.0,
        max_chunk_len: int = 64,
        assignment: Optional[Sequence[Optional[int]]] = None,
        preferred: bool = False,
        reassign: bool = False,
        axis_weight: float = 4.0,
    ) -> None: ...
    def embody(self, hands: ArrayLike, chunk_len: Optional[int] = None) -> npt.NDArray[np.float64]:
        """A whole episode, however long: ``hands`` (hands, T, 7) -> every robot's timeline
        (robots, 1 + approach_len + T, 7), planned in chunks as a policy would send them."""
    def push_chunk(self, start_step: int, hands: ArrayLike) -> npt.NDArray[np.float64]:
        """``hands`` (hands, H, 7) poses at policy steps ``start_step..start_step+H`` ->
        the new joint segment (robots, n, 7) from timeline index ``last_index`` to the end.
        GIL released. Raises InputError or ChunkError; on error the plan is kept."""
    def planned(self, start: int) -> npt.NDArray[np.float64]:
        """(robots, n, 7) configurations from timeline index ``start`` to the end."""
    @property
    def approach(self) -> npt.NDArray[np.float64]:
        """(robots, approach_len, 7): timeline indices 1 to approach_len."""
    def commit_until(self, index: int) -> None:
        """The arms were sent everything before ``index``; it is no longer replaced or kept."""
    def timeline_index(self, step: int) -> Optional[int]: ...
    @property
    def assignment(self) -> Optional[list[Optional[int]]]: ...
    @property
    def approach_len(self) -> int: ...
    @property
    def end(self) -> int: ...
    @property
    def last_index(self) -> Optional[int]: ...
    @property
    def last_report(self) -> Optional[dict[str, Any]]: ...
    @property
    def robot_names(self) -> list[str]: ...

def bench_csv_header() -> str:
    """The header line of ``results.csv`` (no line end), as ``omcbsa bench`` writes it."""

def bench_run(
    entry: str, problem: str, planner: str, timeout: float, approach: bool = True
) -> Tuple[str, Optional[str]]:
    """One run exactly as ``omcbsa bench`` makes it: ``entry`` is the problem's entry of
    ``suite.json`` (JSON text), ``problem`` its file's text. Returns the ``results.csv`` record
    (line end included) and, for a reported success, the solution's JSON text."""

def bench_report(
    suite: Union[str, os.PathLike[str]],
    out: Union[str, os.PathLike[str]],
    planners: Sequence[str],
    timeout: float,
    approach: bool = True,
    jobs: int = 1,
) -> str:
    """``omcbsa bench SUITE --out OUT --report-only``: writes summary.md, the plots and
    index.html of the runs in ``OUT/results.csv`` and returns the summary. Runs nothing."""

def bench_planners() -> list[str]:
    """The planners ``omcbsa bench`` runs by default (every one it can run)."""
