"""Fixtures shared by the tests of the omcbsa Python package.

The command-line program is the reference: these tests run it (``OMCBSA_BIN``, default
``<repo>/target/release/omcbsa``, built by scripts/test-all.sh) on the same files and compare.
"""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def omcbsa_bin() -> Path:
    path = Path(os.environ.get("OMCBSA_BIN", ROOT / "target" / "release" / "omcbsa"))
    if not path.is_file():
        pytest.fail(f"the omcbsa program is missing at {path}: cargo build --release -p omcbsa")
    return path


@pytest.fixture(scope="session")
def suite(omcbsa_bin, tmp_path_factory) -> list[Path]:
    """A small benchmark suite from `omcbsa gen-bench` (2 problems per motion family)."""
    out = tmp_path_factory.mktemp("suite")
    subprocess.run([omcbsa_bin, "gen-bench", out, "--per-family", "2"], check=True,
                   capture_output=True)
    problems = sorted(p for p in out.glob("*.json") if p.name != "suite.json")
    assert len(problems) >= 10, f"gen-bench wrote {len(problems)} problems"
    return problems


def run_cli(omcbsa_bin, *args, stdin=None):
    """Runs the program; returns (exit code, stdout, stderr)."""
    r = subprocess.run([str(omcbsa_bin), *map(str, args)], input=stdin, capture_output=True,
                       text=True)
    return r.returncode, r.stdout, r.stderr


@pytest.fixture(scope="session")
def cli():
    return run_cli


@pytest.fixture
def two_hand_problem() -> dict:
    """Two facing arms, each hand a short line the arm in front of it can follow."""
    return json.loads((ROOT / "python" / "tests" / "data" / "two_hands.json").read_text())
