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
        # Keyword options, read by one helper: an unknown keyword or a value of the wrong type
        # raises TypeError naming it.
        initial: Optional[ArrayLike] = None,
        tcp: Optional[ArrayLike] = None,
        obstacles: Optional[Sequence[Mapping[str, Any]]] = None,
        tolerance: Optional[Tuple[float, float]] = None,
        name: str = "problem",
        model: Optional[Union[str, Sequence[str]]] = None,
    ) -> Problem:
        """``bases`` (robots, 7) and ``hands`` (hands, H, 7): position + quaternion xyzw;
        ``initial`` (robots, 7) joint values; ``tcp`` (robots, 7) or (7,);
        ``tolerance`` (metres, radians); ``name``; ``model``: one model name, or one per
        robot."""
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

class Stream:
    """The executor's frame generator for simulation, without arms: arms at rest at
    ``starts`` (arms, 7) rad, every joint's ``velocity``, ``acceleration`` and ``jerk`` limits
    (arms, 7), control cycles of ``period`` s, steps of at least ``step_time`` s."""

    def __init__(
        self,
        starts: ArrayLike,
        velocity: ArrayLike,
        acceleration: ArrayLike,
        jerk: ArrayLike,
        period: float,
        step_time: float,
    ) -> None: ...
    def push(self, start: int, waypoints: ArrayLike) -> None:
        """Replaces the waypoints from step ``start`` on by ``waypoints`` (arms, n, 7);
        ``InputError`` if refused (a limit broken, too short to stop in)."""
    def run(self, max_cycles: int) -> npt.NDArray[np.float64]:
        """The commands (cycles, arms, 7), rad, until the arms hold or ``max_cycles``."""

def retime(
    waypoints: ArrayLike,
    velocity: ArrayLike,
    acceleration: ArrayLike,
    per_segment: int = 20,
    max_speed: float = ...,
    start: float = 0.0,
    start_speed: float = 0.0,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The time-optimal law (TOPP-RA) along the executor's spline through ``waypoints``
    (n, dof) (several arms' joints side by side share one law), within per-coordinate
    ``velocity`` (rad/s) and ``acceleration`` (rad/s^2) limits and ``max_speed`` waypoints/s,
    from waypoint ``start`` at ``start_speed`` waypoints/s to rest at the end: the grid's path
    parameter (waypoints), path speed (waypoints/s) and time (s); ``t[-1]`` is the duration."""

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

    ``Embodier(setup, **options)``: ``setup`` a Problem whose robots all give ``initial`` (its
    trajectories are not used), or the keywords ``bases`` (robots, 7), ``initial`` (robots, 7)
    and ``dt`` (with ``tcp``, ``obstacles``, ``tolerance`` and ``model`` as for
    ``Problem.from_arrays``). Timeline index 0 is ``initial``, then the approach, then the
    chunks, one per ``dt``. The options, read by one helper (an unknown keyword or a value of
    the wrong type raises TypeError naming it; a bad value InputError):

    - ``planner``: ``omcbsa`` (default) or ``pp``.
    - ``chunk_timeout``: planning time per chunk, s (1.0).
    - ``max_chunk_len``: the longest chunk (64).
    - ``assignment``: which hand each robot takes (None: it holds still), fixed, or tried first
      with ``preferred=True``; ``reassign=True`` lets a chunk with no plan under the
      assignment take a new one from where the arms stand (off: a hand holding an object
      cannot change arms).
    - ``axis_weight`` (0.0): the search's cost of two joint axes nearing one line (on a real
      policy's trajectories the headroom below does better).
    - ``headroom_weight`` (2.0): the cost of a step that brings a joint near its speed limit
      along the hands' motion; ``reserve_weight`` (1.0): the cost of a chunk ending where the
      joints have little room for any next motion.
    - ``rank_starts`` (False): a first chunk of at least 1 s starts each arm where its
      joints' reserve is largest, not nearest where it stands (room for the hands' later fast
      motions, at the cost of a longer approach).
    - ``time_scaling`` (True): a chunk the arms cannot follow at the policy's rate is slowed
      where it must be (the arms fall behind: ``last_report["lag_s"]``), rather than stopped.
    - ``catch_up`` (True): a chunk that cannot be planned otherwise is reached by an approach
      from where the arms hold, dropping the poses it cannot reach in time
      (``last_report["dropped"]``); False: such a chunk raises ``ChunkError``.
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
        axis_weight: float = 0.0,
        headroom_weight: float = 2.0,
        reserve_weight: float = 1.0,
        rank_starts: bool = False,
        time_scaling: bool = True,
        catch_up: bool = True,
    ) -> None: ...
    def embody(self, hands: ArrayLike, chunk_len: Optional[int] = None) -> npt.NDArray[np.float64]:
        """A whole episode, however long: ``hands`` (hands, T, 7) -> every robot's timeline
        (robots, 1 + approach_len + T, 7), planned in chunks as a policy would send them."""
    def push_chunk(self, start_step: int, hands: ArrayLike) -> npt.NDArray[np.float64]:
        """``hands`` (hands, H, 7) poses at policy steps ``start_step..start_step+H`` ->
        the new joint segment (robots, n, 7) from timeline index ``last_index`` to the end.
        GIL released. Raises InputError or ChunkError; on error the plan is kept. While a
        running Cell plans with this Embodier, chunks go through ``cell.push`` (RuntimeError)."""
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
    def last_report(self) -> Optional[dict[str, Any]]:
        """The last chunk's report: ``start_step``, ``index``, ``dropped``, ``recovery``,
        ``blocked`` (why it needed one), ``end``, ``planning_time_s``, ``stats``,
        ``time_factor`` (timeline steps per pose, above 1 when slowed), ``lag_s`` (seconds the
        arms fell behind the policy with it), ``total_lag_s`` (seconds behind in all)."""
    @property
    def robot_names(self) -> list[str]: ...

def aloha_episode(
    path: Union[str, os.PathLike[str]], arms: int = 2, layout: str = "corners"
) -> Tuple[Problem, npt.NDArray[np.float64]]:
    """A recorded episode of the aloha-sim family (``data/aloha_sim/<task>_<seed>.json.gz``)
    on ``arms`` Gen3s standing by ``layout`` (``corners`` or ``rows``) at their retract
    posture: (setup, hands), the setup a Problem for ``Embodier`` (its trajectories the
    hands' first poses), ``hands`` (hands, T, 7) at ``setup.dt``."""

class CellError(RuntimeError):
    """The cell did not do what it was asked. A chunk not sent leaves the arms on their plan."""

    kind: str
    """``start`` (an arm did not start; none moved), ``invalid`` (the chunk's plan failed its
    check), ``refused`` (the executor refused it: a limit at this ``time_scale``, the queue's
    length), ``ended`` (the cell has ended), ``fault`` (ArmFault)."""

class ArmFault(CellError):
    """A fault stopped every arm (the watchdog's quick stop); the cell has ended."""

    arm: str
    """The arm the fault was seen on."""
    fault: str
    cycle: int
    """The control cycle it was detected in."""
    bound_s: float
    """The bound on every arm's stop, s (3 control periods)."""
    stops: list[dict[str, Any]]
    """Per arm: ``arm``, ``cycles_sent``, ``latency_s``, ``error`` (a stop frame that could
    not be sent), ``unanswered`` (stop frames the arm did not confirm)."""

class Cell:
    """The arms an Embodier plans for, streamed while a policy runs.

    ``Cell(embodier, arms, **options)``: ``arms`` maps every robot name of the Embodier (which
    has planned no chunk yet) to its arm's URL: ``kortex://HOST``, ``socketcan://IFACE``,
    ``slcan:///dev/ttyX``, or ``mock-kortex`` / ``mock-can`` (the project's mock arms,
    started for the cell; flags as a query: ``mock-can?emcy-at-sync=60``). Every arm must stand
    where its robot's ``initial`` says (checked); returns once every arm holds there. Options
    (an unknown keyword or a value of the wrong type raises TypeError naming it):

    - ``time_scale``: how many times slower than the policy's rate the arms move (>= 1).
      Default: the models' joint speed limits over the executor's (1.6 for the Gen3). The
      executor also keeps every joint within its acceleration limit, every queued tail ending
      at rest: a fast policy needs more (the first 0.8 s of a 50 Hz ALOHA episode about 10,
      the whole episode about 15); a push that breaks a limit is refused (CellError
      ``refused`` naming the arm, joint and limit).
    - ``rate``: control rate, Hz (100 to 1000); default the arms' slowest (Kortex 1000, CAN
      500, the mocks 100).
    - ``records``: where mock arms write their records (NAME.jsonl; a CAN mock's bus log).
    - ``kortex_user``, ``kortex_password``: for real Gen3s (else OMCBSA_KORTEX_USER and
      OMCBSA_KORTEX_PASSWORD).
    - ``rt_priority``: SCHED_FIFO priority of the streaming threads (50), None for normal.
    - The watchdog: ``missed_cycles`` (2), ``heartbeat_ms`` (100), ``heartbeat_factor`` (1.5),
      ``following_error_timeout_ms`` (10), ``drive_lag_ms`` (10), ``following_error_bound``
      (0.05 rad); the backstops ``feedback_timeout_ms`` (50), ``sdo_timeout_ms`` (100).

    Leaving the cell stops every arm (a quick stop): the ``with`` block's end, an exception,
    Ctrl-C, the interpreter's exit, the object's collection. ``finish()`` lets the queue run
    out first. A queue that runs dry holds the arms (``status()["events"]``: ``queue_dry``);
    the next push moves them on.
    """

    def __init__(
        self,
        embodier: Embodier,
        arms: Mapping[str, str],
        *,
        time_scale: Optional[float] = None,
        rate: Optional[float] = None,
        records: Optional[Union[str, os.PathLike[str]]] = None,
        kortex_user: Optional[str] = None,
        kortex_password: Optional[str] = None,
        rt_priority: Optional[int] = 50,
        missed_cycles: int = 2,
        heartbeat_ms: int = 100,
        heartbeat_factor: float = 1.5,
        following_error_timeout_ms: int = 10,
        drive_lag_ms: int = 10,
        following_error_bound: float = 0.05,
        feedback_timeout_ms: int = 50,
        sdo_timeout_ms: int = 100,
    ) -> None: ...
    def push(self, start_step: int, hands: ArrayLike) -> dict[str, Any]:
        """Plans the chunk (hands, H, 7) at policy steps ``start_step..`` (GIL released), checks
        its plan and hands it to the executor; returns at once with the chunk's report (as
        ``Embodier.last_report``) and ``late`` (its first poses the arms had passed, not
        planned), ``from`` (the waypoint it streams from), ``cycle``, ``attempts``. Raises
        InputError, ChunkError, CellError (not sent) or ArmFault."""
    def status(self) -> dict[str, Any]:
        """``step`` (the waypoint being executed), ``fixed``, ``holding``, ``cycle``,
        ``policy_step`` (the policy step the arms are at, or None), ``lag_s`` (the Embodier's
        lag behind the policy), ``events`` (``queue_dry`` / ``resumed`` since the last call),
        ``arms``: per name ``state``, ``commanded`` and ``measured`` joints (7,),
        ``measured_cycle``, ``following_error``, ``queue_depth``, ``lag_s``. Raises ArmFault
        once after a fault."""
    def finish(self) -> Optional[dict[str, Any]]:
        """Waits for the queue to run out (Ctrl-C still stops the arms), holds, disables the
        drives: ``cycles``, ``holds``, ``halted``, ``report``, ``records``; None if ended."""
    def stop(self) -> Optional[dict[str, Any]]:
        """Stops every arm now (a quick stop); as ``finish``."""
    def __enter__(self) -> Cell: ...
    def __exit__(self, *exc: Any) -> bool: ...
    @property
    def robot_names(self) -> list[str]: ...
    @property
    def time_scale(self) -> float: ...
    @property
    def period(self) -> float:
        """The control period, s."""
    @property
    def step_time(self) -> float:
        """Seconds per waypoint as streamed (dt * time_scale)."""
    @property
    def records(self) -> os.PathLike[str]: ...
    @property
    def running(self) -> bool: ...

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
