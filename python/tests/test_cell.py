"""The live cell end to end: a recorded ALOHA episode (all 401 steps, see aloha_cell.py) pushed
chunk by chunk at its rate through omcbsa.Cell drives two mock Gen3s on Kortex and two mock arms
on CAN; what every mock received is the embodied timeline; a fault stops every arm within 3
periods and the next call raises ArmFault; Ctrl-C stops every arm; the same episode through
`omcbsa online --hands FILE` exits 0, and 1 with a fault. Measured from the mocks' own records
and bus logs. The tests that stop the arms mid-motion push the episode's first PREFIX steps."""

import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import omcbsa
from aloha_cell import (ARMS, EPISODE, PREFIX, STEP_CYCLES, TIME_SCALE, chunks,
                        episode, replay)

HERE = Path(__file__).resolve().parent
QUICK_STOP, ENABLE_OPERATION = 0x0002, 0x000F
TOLERANCE = 1e-6


@pytest.fixture(scope="module")
def cell_episode():
    return episode()


@pytest.fixture(scope="module")
def whole_episode():
    return episode(steps=None)


def read_record(path):
    return [json.loads(line) for line in Path(path).read_text().splitlines()]


def commands(record):
    """(cycles, 7): the motion commands an arm received, rad, one row per control cycle."""
    if any(e.get("kind") == "rpdo" for e in record):
        per_node = [[e["counts"] / 1e7 for e in record
                     if e.get("kind") == "rpdo" and e["node"] == j + 1
                     and e["cw"] == ENABLE_OPERATION] for j in range(7)]
        n = min(len(p) for p in per_node)
        return np.array([p[:n] for p in per_node]).T
    refreshes = [e for e in record if e.get("event") == "refresh"]
    # The first Refresh is the seed, where the arm was measured.
    return np.radians(np.array([e["positions"] for e in refreshes[1:]], dtype=float))


def same(command, q):
    """Within TOLERANCE on every joint (Kortex gives angles in [0, 360) degrees)."""
    d = (command - q + np.pi) % (2 * np.pi) - np.pi
    return np.abs(d).max() <= TOLERANCE


def check_followed(name, cmds, timeline, m):
    """Every waypoint of `timeline` commanded exactly, in order, m cycles after the one before
    (later only where the arm held at the one before: a queue run dry). Returns the cycles."""
    c = next((k for k, cmd in enumerate(cmds) if same(cmd, timeline[0])), None)
    assert c is not None, f"{name}: never commanded its start"
    for i in range(1, len(timeline)):
        while True:
            assert c + m < len(cmds), f"{name}: waypoint {i} of {len(timeline)} never commanded"
            if same(cmds[c + m], timeline[i]):
                c += m
                break
            assert same(cmds[c + 1], timeline[i - 1]), (
                f"{name}: cycle {c + 1} is neither waypoint {i} ({m} cycles after {i - 1}) nor "
                f"a hold at {i - 1}: got {cmds[c + 1]}, waypoints {timeline[i - 1]} and "
                f"{timeline[i]}")
            c += 1
    # The rest: held at the last waypoint (the settle cycles).
    assert all(same(cmd, timeline[-1]) for cmd in cmds[c:]), f"{name}: moved past its end"
    return c


def bus_log(path):
    """(t, id, data bytes, from the host) per frame of a candump -L log (wall clock)."""
    frames = []
    for line in Path(path).read_text().splitlines():
        t, _, frame, direction = line.split()
        ident, data = frame.split("#")
        frames.append((float(t[1:-1]), int(ident, 16), bytes.fromhex(data), direction == "R"))
    return frames


RPDO_NODE_1, SYNC = 0x201, 0x080


def cw(data):
    """The controlword of an RPDO (target counts, then controlword)."""
    return int.from_bytes(data[4:6], "little")


def can_stop(frames):
    """A CAN arm's quick stop: when it was applied (the SYNC after its first quick-stop RPDO,
    wall clock), targets received after it, and the control cycle it took the place of (the
    motion commands before it: one RPDO to node 1 per cycle, none at start-up)."""
    first = next(i for i, (_, ident, data, host) in enumerate(frames)
                 if host and 0x201 <= ident <= 0x27F and cw(data) == QUICK_STOP)
    applied = next(t for t, ident, _, host in frames[first:] if host and ident == SYNC)
    after = sum(1 for _, ident, data, host in frames[first:]
                if host and 0x201 <= ident <= 0x27F and cw(data) != QUICK_STOP)
    cycle = sum(1 for _, ident, _, host in frames[:first] if host and ident == RPDO_NODE_1)
    return applied, after, cycle


def can_emcy(frames):
    """A CAN arm's first EMCY: when (wall clock), and the control cycle whose SYNC it answered
    (the last whose motion commands came before it)."""
    i = next(i for i, (_, ident, _, host) in enumerate(frames) if not host and 0x081 <= ident <= 0x0FF)
    cycles = sum(1 for _, ident, _, host in frames[:i] if host and ident == RPDO_NODE_1)
    return frames[i][0], cycles - 1


def kortex_stop(record):
    """A Gen3's emergency stop: when (monotonic clock), Refreshes after it, and the control
    cycle it took the place of (the Refreshes before it but the start-up's seed)."""
    i = next(i for i, e in enumerate(record) if e.get("event") == "estop")
    t = record[i]["t"]
    after = sum(1 for e in record if e.get("event") == "refresh" and e["t"] > t)
    cycle = sum(1 for e in record[:i] if e.get("event") == "refresh") - 1
    return t, after, cycle


def stops(records, wall_minus_monotonic):
    """Per arm: (when its stop reached it, wall clock; commands it received after it; the
    control cycle it took the place of)."""
    out = {}
    for name, url in ARMS.items():
        if url.startswith("mock-can"):
            out[name] = can_stop(bus_log(records / f"{name}.log"))
        else:
            t, after, cycle = kortex_stop(read_record(records / f"{name}.jsonl"))
            out[name] = (t + wall_minus_monotonic, after, cycle)
    return out


def test_an_episode_at_its_rate_drives_every_arm_along_the_embodied_timeline(whole_episode,
                                                                            tmp_path):
    setup, hands = whole_episode
    assert hands.shape[1] == 401
    e = omcbsa.Embodier(setup)
    started = time.monotonic()
    with omcbsa.Cell(e, ARMS, time_scale=TIME_SCALE, records=tmp_path) as cell:
        assert cell.robot_names == list(ARMS)
        m = round(cell.step_time / cell.period)
        assert m * cell.period == pytest.approx(cell.step_time)
        assert m == STEP_CYCLES
        before = cell.status()
        assert all(a["state"] == "holding" for a in before["arms"].values())
        reports, during = [], []

        def pushed(s, p):
            reports.append(p)
            if s == 200:
                during.append(cell.status())

        timeline = replay(cell, e, hands, on_push=pushed)
        # The cell's Embodier takes chunks only through the cell.
        with pytest.raises(RuntimeError, match="push chunks with cell.push"):
            e.push_chunk(100, hands[:, :4])
        end = cell.finish()
    took = time.monotonic() - started
    print(f"{len(reports)} chunks, {timeline.shape[1]} waypoints, {took:.1f} s; {end['report']}")
    assert end["halted"] is False
    assert len(reports) == len(chunks(hands))
    assert all(r["late"] == 0 and r["attempts"] == 1 for r in reports), reports
    assert e.last_report["total_lag_s"] == reports[-1]["total_lag_s"]
    for key in ("time_factor", "lag_s", "total_lag_s"):
        assert key in e.last_report
    # Mid-episode the arms were moving what was pushed before while the policy pushed the rest.
    assert during[0]["arms"]["south_west"]["state"] == "moving"
    assert during[0]["arms"]["south_west"]["queue_depth"] > 0
    # Two arms take the hands, two hold still.
    assert e.assignment == [0, 1, None, None]
    assert np.ptp(timeline[2:], axis=1).max() == 0.0
    assert np.ptp(timeline[:2], axis=1).max() > 0.1
    # Every arm's record is the embodied timeline: each waypoint commanded to 1e-6 rad.
    for i, name in enumerate(ARMS):
        record = read_record(tmp_path / f"{name}.jsonl")
        assert not [x for x in record if x.get("kind") == "violation" or x.get("event") == "refused"]
        check_followed(name, commands(record), timeline[i], m)


def test_a_fault_mid_episode_stops_every_arm_within_3_periods_and_raises_arm_fault(cell_episode,
                                                                                  tmp_path):
    setup, hands = cell_episode
    e = omcbsa.Embodier(setup)
    # north_east (CAN, moving) sends an EMCY at SYNC 300, 3 s into the motion of about 12 s,
    # while the policy is still pushing: the push or the status call after it raises.
    arms = dict(ARMS, north_east="mock-can?emcy-at-sync=300")
    cell = omcbsa.Cell(e, arms, time_scale=TIME_SCALE, records=tmp_path)
    deadline = time.monotonic() + 40
    with pytest.raises(omcbsa.ArmFault) as fault:
        replay(cell, e, hands)
        while time.monotonic() < deadline:
            cell.status()
            time.sleep(0.01)
    offset = time.time() - time.monotonic()
    f = fault.value
    print(f)
    assert (f.arm, f.kind) == ("north_east", "fault")
    assert "EMCY" in f.fault and "0x2310" in f.fault
    assert sorted(s["arm"] for s in f.stops) == sorted(ARMS)
    assert f.bound_s == pytest.approx(3 * cell.period)
    # Once: afterwards the cell has ended.
    with pytest.raises(omcbsa.CellError) as ended:
        cell.push(PREFIX, hands[:, -4:])
    assert ended.value.kind == "ended" and "fault" in str(ended.value)
    # From the fault's first sign (the EMCY on north_east's bus) to each arm's stop, in control
    # cycles as the mocks received them (the arms stream in lockstep: cycle k is the k-th motion
    # command of every arm), so that a mock descheduled on a loaded machine does not count; the
    # same on the mocks' clocks, printed.
    sign_t, sign_cycle = can_emcy(bus_log(tmp_path / "north_east.log"))
    for name, (t, after, cycle) in stops(tmp_path, offset).items():
        print(f"{name}: stopped in place of cycle {cycle}, the fault's first sign at cycle "
              f"{sign_cycle}; {(t - sign_t) / cell.period:.2f} periods on the mocks' clocks")
        assert 0 < cycle - sign_cycle <= 3, (
            f"{name}: stopped in place of cycle {cycle}, the first sign at cycle {sign_cycle}")
        assert after == 0, f"{name}: {after} commands after its stop"


def assert_stopped_while_moving(records, since):
    """Every arm got a stop (wall clock) after `since`, in place of a cycle before the motion's
    end (the episode's steps alone take PREFIX x STEP_CYCLES cycles), and no command after it."""
    for name, (t, after, cycle) in stops(records, time.time() - time.monotonic()).items():
        print(f"{name}: stopped in place of cycle {cycle}, {t - since:.3f} s after")
        assert t > since, f"{name}: stopped before"
        assert cycle < PREFIX * STEP_CYCLES, f"{name}: stopped at cycle {cycle}, past its motion"
        assert after == 0, f"{name}: {after} commands after its stop"


def run_cell_script(records, how, pushed=lambda proc: None):
    """Runs aloha_cell.py; `pushed(proc)` once the policy has pushed three chunks (the arms
    moving). Returns (return code, stdout, stderr, when the three had been pushed)."""
    proc = subprocess.Popen([sys.executable, str(HERE / "aloha_cell.py"), str(records), how],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for _ in range(3):
            line = proc.stdout.readline()
            assert line.startswith("pushed"), line + proc.stderr.read()
        since = time.time()
        pushed(proc)
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    return proc.returncode, out, err, since


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["ctrl_c", "sigterm"])
def test_ctrl_c_or_sigterm_stops_every_arm(tmp_path, sig):
    def send(proc):
        time.sleep(1.0)
        proc.send_signal(sig)

    code, out, err, since = run_cell_script(tmp_path, "finish", send)
    assert "finished" not in out
    if sig == signal.SIGINT:
        assert code != 0 and "KeyboardInterrupt" in err, err
    else:
        # The Cell's handler: a SystemExit with the status the default would give.
        assert code == 128 + signal.SIGTERM, err
    assert_stopped_while_moving(tmp_path, since)


@pytest.mark.parametrize("how", ["raise", "exit"])
def test_an_exception_or_the_interpreters_exit_stops_every_arm(tmp_path, how):
    code, out, err, since = run_cell_script(tmp_path, how)
    if how == "raise":
        assert code == 1 and "RuntimeError: the policy failed" in err, err
    else:
        assert code == 0 and "leaving" in out, err
    assert_stopped_while_moving(tmp_path, since)


def test_the_same_episode_through_the_command_line_exits_0_and_1_with_a_fault(
        cell_episode, whole_episode, cli, omcbsa_bin, tmp_path):
    setup, hands = cell_episode
    (tmp_path / "setup.json").write_text(setup.to_json())
    arms = [f"--arm={n}={u}" for n, u in ARMS.items()]
    common = ["online", "--setup", tmp_path / "setup.json", "--time-scale", str(TIME_SCALE)]
    # The whole recorded episode itself, cut into the same chunks.
    code, out, err = cli(omcbsa_bin, *common, "--hands", EPISODE, "--chunk-len", "16",
                         "--stride", "8", "--records", tmp_path / "ok", *arms)
    print(out, err)
    assert code == 0, err
    assert f"done: {len(chunks(whole_episode[1]))} chunks streamed, 0 not" in out
    for name in ARMS:
        record = read_record(tmp_path / "ok" / f"{name}.jsonl")
        assert not [x for x in record if x.get("kind") == "violation" or x.get("event") == "refused"]
    # The same chunks as JSON lines, with a fault on north_east.
    lines = tmp_path / "chunks.jsonl"
    lines.write_text("".join(json.dumps({"start_step": s, "hands": [
        [{"position": p[:3].tolist(), "quat_xyzw": p[3:].tolist()} for p in hand]
        for hand in chunk]}) + "\n" for s, chunk in chunks(hands)))
    faulty = [a.replace("north_east=mock-can", "north_east=mock-can?emcy-at-sync=300")
              for a in arms]
    code, out, err = cli(omcbsa_bin, *common, "--hands", lines, "--records", tmp_path / "fault",
                         *faulty)
    print(out, err)
    assert code == 1, err
    assert "stopped by a fault" in err and "north_east" in err


def test_bad_cells_and_lines_are_refused_with_the_field_named(cell_episode, cli, omcbsa_bin,
                                                             tmp_path):
    setup, hands = cell_episode
    e = omcbsa.Embodier(setup)
    with pytest.raises(omcbsa.InputError, match=r'arms\["left"\].*unknown arm URL'):
        omcbsa.Cell(e, dict(ARMS, left="tcp://x"))
    with pytest.raises(omcbsa.InputError, match='robot "south_east" has no arm'):
        omcbsa.Cell(e, {k: v for k, v in ARMS.items() if k != "south_east"})
    with pytest.raises(TypeError, match="unexpected keyword argument \"speed\""):
        omcbsa.Cell(e, ARMS, speed=2)
    with pytest.raises(TypeError, match="time_scale: expected a number"):
        omcbsa.Cell(e, ARMS, time_scale="fast")
    with pytest.raises(omcbsa.InputError, match="time_scale 0.5"):
        omcbsa.Cell(e, ARMS, time_scale=0.5)
    (tmp_path / "setup.json").write_text(setup.to_json())
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"start_step": 0, "hands": [[{"position": [0, 0], "quat_xyzw": [0, 0, 0, 1]}]]}\n')
    code, _, err = cli(omcbsa_bin, "online", "--setup", tmp_path / "setup.json", "--hands", bad,
                       *[f"--arm={n}={u}" for n, u in ARMS.items()], "--records", tmp_path)
    assert code == 2
    assert "line 1: hands[0][0].position: " in err, err
    code, _, err = cli(omcbsa_bin, "online", "--setup", tmp_path / "setup.json", "--hands", "-",
                       "--arm", "south_west=mock-kortex")
    assert code == 2 and 'robot "north_east" has no arm' in err, err
