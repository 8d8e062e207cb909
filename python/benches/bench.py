"""Benchmark of the Python package: what a call from Python costs on top of the planner.

    python python/benches/bench.py SUITE_DIR [--limit N] [--planner omcbsa] [--fk-n 100000]

- Planning: for each suite problem (from `omcbsa gen-bench`), the wall time of
  `omcbsa.plan()` as Python sees it against the planner's own planning time
  (`solution.planning_time_s`, measured inside the library around the core call). The rest is
  the call's overhead: reading the problem into the core's storage, allocating the planner's
  pools, validating the plan before it is returned, building the NumPy result.
- Kinematics: vectorised `omcbsa.fk` on an (N, 7) array against a Python loop of single
  calls, in configurations per second.

Prints Markdown tables. Times are medians over the problems (each planned once).
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import omcbsa


def plan_overhead(problems, planner, timeout):
    rows = []
    for path in problems:
        problem = omcbsa.Problem(path)
        t0 = time.perf_counter()
        s = omcbsa.plan(problem, planner=planner, timeout=timeout)
        wall = time.perf_counter() - t0
        if not s.solved:
            continue
        t0 = time.perf_counter()
        omcbsa.validate(problem, s)
        check = time.perf_counter() - t0
        rows.append((problem.robots, wall, s.planning_time_s, check))
    return rows


def fk_rates(n):
    rng = np.random.default_rng(0)
    lim = np.array([np.pi, 2.24, np.pi, 2.57, np.pi, 2.09, np.pi])
    q = rng.uniform(-lim, lim, size=(n, 7))
    t0 = time.perf_counter()
    batch = omcbsa.fk("kinova_gen3", q)
    vec = time.perf_counter() - t0
    m = max(n // 10, 1)
    t0 = time.perf_counter()
    single = [omcbsa.fk("kinova_gen3", q[i]) for i in range(m)]
    loop = time.perf_counter() - t0
    assert np.array_equal(np.array(single), batch[:m])
    return n / vec, m / loop


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("suite", type=Path)
    ap.add_argument("--limit", type=int, default=0, help="at most this many problems per arm count")
    ap.add_argument("--planner", default="omcbsa")
    ap.add_argument("--timeout", type=float, default=5.0)
    ap.add_argument("--fk-n", type=int, default=100_000)
    args = ap.parse_args()

    by_arms = {}
    for p in sorted(args.suite.glob("*.json")):
        if p.name == "suite.json":
            continue
        by_arms.setdefault(p.stem.split("_")[-2], []).append(p)
    problems = [p for ps in by_arms.values() for p in (ps[: args.limit] if args.limit else ps)]
    rows = plan_overhead(problems, args.planner, args.timeout)
    if not rows:
        sys.exit("no problem was solved")

    print(f"Planner {args.planner}, {len(rows)} solved of {len(problems)} problems:\n")
    print("| arms | solved | planning (ms, p50) | Python call (ms, p50) | call / planning (p50) "
          "| validation alone (ms, p50) |")
    print("|---:|---:|---:|---:|---:|---:|")
    groups = sorted({r[0] for r in rows}) + ["all"]
    for g in groups:
        rs = [r for r in rows if g == "all" or r[0] == g]
        med = lambda k: statistics.median(k(r) for r in rs)  # noqa: E731
        print(f"| {g} | {len(rs)} | {med(lambda r: r[2]) * 1e3:.2f} | {med(lambda r: r[1]) * 1e3:.2f} "
              f"| {med(lambda r: r[1] / r[2]):.2f} | {med(lambda r: r[3]) * 1e3:.2f} |")

    vec, loop = fk_rates(args.fk_n)
    print(f"\nForward kinematics, {args.fk_n} configurations:\n")
    print("| call | configurations per second |")
    print("|---|---:|")
    print(f"| `omcbsa.fk(model, q)` on an ({args.fk_n}, 7) array | {vec:,.0f} |")
    print(f"| Python loop of `omcbsa.fk(model, q[i])` | {loop:,.0f} |")
    print(f"| ratio | {vec / loop:.1f}x |")


if __name__ == "__main__":
    main()
