"""`python -m omcbsa.sweep` on a local Ray cluster of two workers, on a 40-problem suite (5 per
family): its results equal `omcbsa bench`'s (status and path length of every run), a worker
killed in the middle of a run loses nothing and duplicates nothing, `--resume` runs only what
is missing, and the summary and plots are the host's.

Skipped only when the ray extra is not installed (scripts/test-all.sh installs it)."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("ray", reason="the ray extra is not installed: pip install ./python[ray]")
pytest.importorskip("tqdm", reason="the ray extra is not installed: pip install ./python[ray]")

PLANNERS = "omcbsa,pp"
# Long enough that no run stops at its deadline on a loaded machine: the runs are then
# deterministic, and two runs of one problem give the same plan.
TIMEOUT = "60"
SETTING = f"timeout={TIMEOUT}_approach=on"


def read_rows(path: Path) -> dict:
    """(problem, planner) -> row, each run exactly once."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    keys = [(r["problem"], r["planner"]) for r in rows]
    assert len(keys) == len(set(keys)), f"{path}: a run written twice"
    return dict(zip(keys, rows))


def sweep_cmd(suite: Path, out: Path, *extra: str) -> list:
    return [sys.executable, "-m", "omcbsa.sweep", str(suite), "--planners", PLANNERS,
            "--param", f"timeout={TIMEOUT}", "--num-cpus", "2", "--out", str(out),
            "--no-progress", *extra]


def sweep(suite: Path, out: Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run(sweep_cmd(suite, out, *extra), capture_output=True, text=True,
                          timeout=900)


@pytest.fixture(scope="module")
def suite40(omcbsa_bin, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("suite40")
    subprocess.run([omcbsa_bin, "gen-bench", out, "--per-family", "5"], check=True,
                   capture_output=True)
    assert len(json.loads((out / "suite.json").read_text())["problems"]) == 40
    return out


@pytest.fixture(scope="module")
def bench(omcbsa_bin, suite40, tmp_path_factory) -> dict:
    """`omcbsa bench`'s rows: the reference."""
    out = tmp_path_factory.mktemp("bench")
    r = subprocess.run([omcbsa_bin, "bench", suite40, "--planners", PLANNERS, "--timeout",
                        TIMEOUT, "--jobs", "2", "--out", out], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = read_rows(out / "results.csv")
    assert len(rows) == 80
    return rows


def assert_equal_to_bench(rows: dict, bench: dict):
    assert rows.keys() == bench.keys()
    for key, want in bench.items():
        got = rows[key]
        for column in ("status", "valid", "success", "path_length_rad", "expansions"):
            assert got[column] == want[column], (key, column, got[column], want[column])
    # Not all trivial: most runs solve.
    assert sum(r["success"] == "true" for r in rows.values()) >= 60


@pytest.fixture(scope="module")
def swept(suite40, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("sweep")
    r = sweep(suite40, out)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "80 runs in" in r.stdout, r.stdout
    return out


def test_a_sweep_gives_the_bench_results_and_report(swept, bench):
    setting = swept / SETTING
    assert_equal_to_bench(read_rows(setting / "results.csv"), bench)
    summary = (setting / "summary.md").read_text()
    assert "## Success rate by family" in summary and "## Per planner and number of arms" in summary
    for plot in ("success_overall", "success_by_robots", "success_by_family", "runtime_cdf"):
        assert (setting / f"{plot}.svg").stat().st_size > 1000
    assert (setting / "index.html").exists()
    # The solutions of the successes, where `omcbsa bench` keeps them.
    solved = [k for k, r in bench.items() if r["status"] == "solved"]
    for problem, planner in solved:
        solution = json.loads((setting / "solutions" / planner / f"{problem}.json").read_text())
        assert solution["status"] == "solved" and solution["problem"] == problem
    stats = json.loads((swept / "sweep.json").read_text())
    assert (stats["runs"], stats["failed"], stats["cpus"]) == (80, 0, 2)


def title(pid: int) -> str:
    """A process's title (Ray sets it to `ray::plan` while a worker runs the task, `ray::IDLE`
    after); empty once it is gone."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_text()
    except OSError:
        return ""


def kill_a_worker_mid_run() -> int | None:
    """Kills a Ray worker in the middle of a run: stopped first, so that its title, read while
    it cannot move on, says it is inside the task when it dies. Its pid, or None."""
    ps = subprocess.run(["ps", "-eo", "pid=,args="], capture_output=True, text=True).stdout
    for pid in (int(line.split()[0]) for line in ps.splitlines() if "ray::plan" in line):
        try:
            os.kill(pid, signal.SIGSTOP)
        except ProcessLookupError:
            continue
        if "ray::plan" in title(pid):
            os.kill(pid, signal.SIGKILL)
            return pid
        os.kill(pid, signal.SIGCONT)
    return None


def test_a_worker_killed_mid_sweep_loses_and_duplicates_nothing(suite40, bench, tmp_path):
    proc = subprocess.Popen(sweep_cmd(suite40, tmp_path), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    results = tmp_path / SETTING / "results.csv"
    killed = None
    deadline = time.monotonic() + 600
    while killed is None and proc.poll() is None and time.monotonic() < deadline:
        done = results.read_text().count("\n") - 1 if results.exists() else 0
        if done >= 2:
            killed = kill_a_worker_mid_run()
        time.sleep(0.05)
    out, err = proc.communicate(timeout=900)
    assert killed is not None, f"no worker was busy mid-sweep to kill: {out}{err}"
    assert proc.returncode == 0, out + err
    assert title(killed) == "", "the killed worker still runs"
    # The run it was in the middle of was run again by Ray: every run is there, once.
    assert "80 runs in" in out, out
    assert_equal_to_bench(read_rows(results), bench)


def test_resume_runs_only_what_is_missing(suite40, swept, bench, tmp_path):
    source = (swept / SETTING / "results.csv").read_text().splitlines(keepends=True)
    (tmp_path / SETTING).mkdir()
    results = tmp_path / SETTING / "results.csv"
    # The header, 30 runs, and a row cut short by an interruption.
    results.write_text("".join(source[:31]) + source[31][:20])
    refused = sweep(suite40, tmp_path)
    assert refused.returncode == 2 and "--resume" in refused.stderr, refused.stderr
    r = sweep(suite40, tmp_path, "--resume")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "50 runs in" in r.stdout and "(30 already done)" in r.stdout, r.stdout
    assert_equal_to_bench(read_rows(results), bench)
    again = sweep(suite40, tmp_path, "--resume")
    assert again.returncode == 0 and "0 runs in" in again.stdout, again.stdout


def test_bad_arguments_are_refused_by_name(suite40, tmp_path):
    r = subprocess.run([sys.executable, "-m", "omcbsa.sweep", str(suite40), "--planners",
                        "omcbsa,nope", "--out", str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 2 and "unknown planner 'nope'" in r.stderr, r.stderr
    r = subprocess.run([sys.executable, "-m", "omcbsa.sweep", str(suite40), "--param",
                        "timeout=1,-2", "--out", str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 2 and "'-2' is not a positive number" in r.stderr, r.stderr
