"""Benchmark sweeps on a Ray cluster: every planner on every problem of a suite, under every
setting of the swept parameters, one Ray task per run.

    python -m omcbsa.sweep SUITE --planners omcbsa,pp --param timeout=1,5 [--address auto]
        [--out DIR] [--resume] [--num-cpus N]

Each task is one run of ``omcbsa bench`` (the same code, through the package's native
module: load the problem, plan with the bench's pools, re-validate a success, path quality),
so its results equal the command's. Each setting gets the output of ``omcbsa bench``:
``OUT/<setting>/results.csv``, ``summary.md``, the plots, ``index.html`` with the 3D views
and the solutions they show, written by the host's own code (``omcbsa bench --report-only``).

Beside the settings' directories: ``sweep.json`` (runs, wall time, CPUs, runs per second, the
mean time inside a task, and Ray's overhead per run: the CPU time of the sweep not spent
inside the runs) and ``tasks.csv`` (each run's wall and CPU time inside its task).

Parameters: ``timeout`` (seconds per run, default 5) and ``approach`` (``on`` or ``off``,
default ``on``: ``off`` is ``omcbsa bench --no-approach``). A setting's directory is named by
its values, e.g. ``timeout=1_approach=on``.

Nothing is lost and nothing counted twice: a task whose worker dies is run again by Ray
(``max_retries``); the driver writes each run's row once, as its result comes, flushed, so an
interrupted sweep keeps what it did, and ``--resume`` runs only what its results files lack.
Without ``--address`` a local Ray is started on this machine (``--num-cpus`` workers, default
all cores); with ``--address auto`` (or ``ray://host:10001``) the sweep joins that cluster,
whose nodes need this package installed. Needs the ``ray`` extra: ``pip install ./python[ray]``.
"""

from __future__ import annotations

import argparse
import csv
import io
import itertools
import json
import os
import sys
import time
from pathlib import Path
from typing import Iterable

from . import _omcbsa

#: Parameters a sweep may vary, with their defaults (as the command line spells them).
PARAMS = {"timeout": ["5"], "approach": ["on"]}


class Usage(Exception):
    """Bad arguments or files: the message says what and where (exit code 2)."""


#: How often Ray runs a task again whose worker died (a planner's failure is a row, not an
#: exception: it is never retried).
MAX_RETRIES = 3


def settings(params: dict[str, list[str]]) -> list[dict[str, str]]:
    """Every combination of the parameters' values, in the order given."""
    names = list(params)
    return [dict(zip(names, values)) for values in itertools.product(*params.values())]


def setting_name(setting: dict[str, str]) -> str:
    return "_".join(f"{k}={v}" for k, v in setting.items())


def parse_params(given: Iterable[str]) -> dict[str, list[str]]:
    """``NAME=v1,v2`` arguments over the defaults; a clear error for anything else."""
    params = {k: list(v) for k, v in PARAMS.items()}
    for arg in given:
        name, sep, values = arg.partition("=")
        if not sep or name not in PARAMS or not values:
            raise Usage(f"--param {arg!r}: expected NAME=v1,v2,... with NAME one of "
                        f"{', '.join(PARAMS)}")
        vals = values.split(",")
        for v in vals:
            if name == "timeout":
                try:
                    ok = float(v) > 0 and float(v) != float("inf")
                except ValueError:
                    ok = False
                if not ok:
                    raise Usage(f"--param timeout: {v!r} is not a positive number of seconds")
            if name == "approach" and v not in ("on", "off"):
                raise Usage(f"--param approach: {v!r} is neither on nor off")
        params[name] = vals
    return params


def read_done(path: Path, header: str) -> set[tuple[str, str]]:
    """The (problem, planner) runs in a results file, as ``omcbsa bench`` reads it: a last
    line cut short by an interruption is dropped (from the file too), another header refused."""
    if not path.exists():
        return set()
    data = path.read_bytes()
    complete = data.rfind(b"\n") + 1
    if complete < len(data):
        with open(path, "r+b") as f:
            f.truncate(complete)
    if complete == 0:
        return set()
    reader = csv.reader(io.StringIO(data[:complete].decode()))
    found = ",".join(next(reader))
    if found != header:
        raise Usage(f"{path}: its header is `{found}`, this version writes `{header}`: "
                    "use another --out directory")
    problem, planner = header.split(",").index("problem"), header.split(",").index("planner")
    return {(row[problem], row[planner]) for row in reader}


class Results:
    """One setting's output directory: rows appended and flushed as they come, solutions
    kept where ``omcbsa bench`` keeps them, each run at most once."""

    def __init__(self, out: Path, header: str, resume: bool):
        self.out = out
        out.mkdir(parents=True, exist_ok=True)
        self.path = out / "results.csv"
        self.done = read_done(self.path, header)
        if self.done and not resume:
            raise Usage(f"{self.path} already holds {len(self.done)} runs: --resume to run "
                        "only the others, or another --out directory")
        new = not self.path.exists() or self.path.stat().st_size == 0
        self.file = open(self.path, "a", newline="")
        if new:
            self.file.write(header + "\n")
            self.file.flush()

    def add(self, key: tuple[str, str], record: str, solution: str | None) -> bool:
        """Writes a run's row (and solution); `False`, writing nothing, if it is there."""
        if key in self.done:
            return False
        if solution is not None:
            problem, planner = key
            path = self.out / "solutions" / planner / f"{problem}.json"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(solution)
        self.file.write(record)
        self.file.flush()
        self.done.add(key)
        return True


def run(args: argparse.Namespace) -> int:
    import ray
    from tqdm import tqdm

    suite = Path(args.suite)
    try:
        problems = json.loads((suite / "suite.json").read_text())["problems"]
    except (OSError, ValueError, KeyError) as e:
        raise Usage(f"{suite / 'suite.json'}: not a suite index ({e})") from e
    known = _omcbsa.bench_planners()
    planners = [p for p in args.planners.split(",") if p] if args.planners else known
    for p in planners:
        if p not in known:
            raise Usage(f"--planners: unknown planner {p!r} (known: {', '.join(known)})")
    header = _omcbsa.bench_csv_header()
    out = Path(args.out) if args.out else suite / "sweep"
    every = settings(parse_params(args.param))
    runs = []  # (setting, Results, entry, planner)
    for setting in every:
        results = Results(out / setting_name(setting), header, args.resume)
        for entry in problems:
            for planner in planners:
                if (entry["name"], planner) not in results.done:
                    runs.append((setting, results, entry, planner))
    skipped = len(problems) * len(planners) * len(every) - len(runs)

    init = dict(include_dashboard=False, logging_level="warning", log_to_driver=False)
    if args.address:
        ray.init(address=args.address, **init)
    else:
        ray.init(num_cpus=args.num_cpus, **init)
    cpus = int(ray.cluster_resources().get("CPU", 1))

    @ray.remote(max_retries=MAX_RETRIES, retry_exceptions=False)
    def plan(entry: str, problem, planner: str, timeout: float, approach: bool):
        from omcbsa import _omcbsa as native

        start, cpu = time.perf_counter(), time.process_time()
        record, solution = native.bench_run(entry, problem, planner, timeout, approach)
        return record, solution, time.perf_counter() - start, time.process_time() - cpu

    texts = {}
    pending = {}
    for setting, results, entry, planner in runs:
        name = entry["name"]
        if name not in texts:
            texts[name] = ray.put((suite / entry["file"]).read_text())
        ref = plan.remote(json.dumps(entry), texts[name], planner, float(setting["timeout"]),
                          setting["approach"] == "on")
        pending[ref] = (results, (name, planner))

    start = time.perf_counter()
    written, failed, task_s, task_cpu_s = 0, [], 0.0, 0.0
    # Each run's time inside its task, wall and CPU: what the runs cost, Ray aside.
    tasks = open(out / "tasks.csv", "a" if args.resume else "w", newline="")
    if tasks.tell() == 0:
        tasks.write("setting,problem,planner,task_wall_s,task_cpu_s\n")
    bar = tqdm(total=len(runs), unit="run", desc=f"{cpus} CPUs", disable=args.no_progress,
               file=sys.stderr)
    waiting = list(pending)
    while waiting:
        ready, waiting = ray.wait(waiting, num_returns=min(len(waiting), 16), timeout=1.0)
        for ref in ready:
            results, key = pending.pop(ref)
            try:
                record, solution, seconds, cpu_seconds = ray.get(ref)
            except (ray.exceptions.RayError, ValueError) as e:
                failed.append((results.out.name, key, str(e).splitlines()[0]))
            else:
                if results.add(key, record, solution):
                    written += 1
                    task_s += seconds
                    task_cpu_s += cpu_seconds
                    tasks.write(f"{results.out.name},{key[0]},{key[1]},{seconds},{cpu_seconds}\n")
            bar.update(1)
    bar.close()
    tasks.close()
    wall = time.perf_counter() - start

    for setting in every:
        _omcbsa.bench_report(suite, out / setting_name(setting), planners,
                             float(setting["timeout"]), setting["approach"] == "on", cpus)
    stats = {
        "runs": written, "skipped_done": skipped, "failed": len(failed), "cpus": cpus,
        "wall_s": wall, "runs_per_s": written / wall if wall > 0 else None,
        "task_s_mean": task_s / written if written else None,
        "task_cpu_s_mean": task_cpu_s / written if written else None,
        # What Ray adds to each run: the CPU time of the sweep not spent in the runs.
        "overhead_per_run_s": (cpus * wall - task_s) / written if written else None,
    }
    (out / "sweep.json").write_text(json.dumps(stats, indent=2) + "\n")
    print(f"{written} runs in {wall:.1f} s on {cpus} CPUs ({skipped} already done); "
          f"results in {out}/<setting>/ (results.csv, summary.md, plots, index.html)")
    for setting_dir, (problem, planner), why in failed:
        print(f"not run: {planner} on {problem} ({setting_dir}): {why}", file=sys.stderr)
    if failed:
        print(f"{len(failed)} runs could not be made: --resume runs them", file=sys.stderr)
        return 1
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m omcbsa.sweep", description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("suite", help="suite directory (omcbsa gen-bench)")
    p.add_argument("--planners", help="comma-separated planners (default: every one "
                   "omcbsa bench runs)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=V1,V2",
                   help="values of a parameter to sweep: timeout (s), approach (on/off)")
    p.add_argument("--out", help="output directory (default SUITE/sweep)")
    p.add_argument("--address", help="Ray cluster to join (e.g. auto); default: a local Ray")
    p.add_argument("--num-cpus", type=int, default=os.cpu_count(),
                   help="workers of the local Ray (without --address)")
    p.add_argument("--resume", action="store_true", help="run only what the results lack")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    try:
        import ray  # noqa: F401
        import tqdm  # noqa: F401
    except ImportError as e:
        print(f"omcbsa.sweep needs the ray extra (pip install ./python[ray]): {e}", file=sys.stderr)
        return 2
    try:
        return run(args)
    except Usage as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
