"""A recorded ALOHA episode on a cell of four mock arms, for the Cell's tests (test_cell.py) and
run on its own by the tests of leaving the cell: ``python aloha_cell.py RECORDS_DIR [HOW]``
streams the episode, printing a line per chunk pushed, and then (HOW) lets the queue run out in
a ``with`` block (``finish``, the default: Ctrl-C is sent meanwhile), raises in the block
(``raise``), or leaves the interpreter with the cell running (``exit``).

The cell: the aloha-sim family's four Gen3s at the table's corners; the two that take the hands
(south_west, north_east) start where the episode's first poses put them (a policy starts from
where the hands are), the other two hold still. south_west and north_west are mock Gen3s on
Kortex, north_east and south_east mock arms on CAN: one arm of each kind moves, one holds.

The arms follow slower than the policy's 50 Hz: the executor keeps every joint within the Gen3's
acceleration limits (Kinova's 1 rad/s^2 for joints 1-4), with every queued tail ending at rest;
this episode's embodied timeline alone needs a uniform slow-down of about 8 on joints 3-4, the
tails at rest about 15. At ``TIME_SCALE`` 15 a step lasts 30 control cycles of the mocks' 10 ms,
so that every waypoint is commanded exactly at a cycle. The policy keeps its rate as the arms
do: chunk ``s`` is pushed ``LEAD`` steps before step ``s`` is due, a step lasting the cell's step
time (as a policy that watches the arms and infers ahead would, and as ``omcbsa online --hands
FILE`` replays).
"""

import sys
import time
from pathlib import Path

import numpy as np

import omcbsa

ROOT = Path(__file__).resolve().parents[2]
EPISODE = ROOT / "data" / "aloha_sim" / "transfer_100.json.gz"

#: Steps of the episode's 401 pushed by the tests that stop the arms mid-motion (its first 0.8 s
#: at 50 Hz); the test of the record and the command line's push all of them.
PREFIX = 40
CHUNK, STRIDE = 16, 8
#: Steps a chunk is pushed before its first step is due (the command line's default --lead;
#: the cell keeps at least the two steps after the one streamed out of a new plan's reach).
LEAD = 4
TIME_SCALE = 15.0
#: Control cycles per policy step: TIME_SCALE times the episode's 20 ms over the mocks' 10 ms.
STEP_CYCLES = 30

ARMS = {
    "south_west": "mock-kortex",
    "north_east": "mock-can",
    "north_west": "mock-kortex",
    "south_east": "mock-can",
}

def episode(steps=PREFIX):
    """(setup Problem, hands (2, steps, 7)): the hand-taking arms start at the first poses."""
    setup, hands = omcbsa.aloha_episode(EPISODE, arms=4)
    d = setup.to_dict()
    for i in range(2):
        r = d["robots"][i]
        pose = lambda p: np.array(p["position"] + p["quat_xyzw"])  # noqa: E731
        q, ok = omcbsa.ik("kinova_gen3", hands[i, 0], seeds=np.array(r["initial"]),
                          base=pose(r["base"]), tcp=pose(r["tcp"]))
        assert ok, f"robot {i} cannot reach hand {i}'s first pose"
        r["initial"] = q.tolist()
    return omcbsa.Problem(d), hands[:, :steps]


def chunks(hands):
    """(start_step, hands) of the policy's chunks: CHUNK poses every STRIDE steps."""
    steps = hands.shape[1]
    return [(s, hands[:, s:min(s + CHUNK, steps)]) for s in range(0, steps, STRIDE)]


def replay(cell, embodier, hands, on_push=None):
    """Pushes the chunks at the policy's rate as the arms keep it (chunk s at s - LEAD times the
    cell's step time after the first); returns the embodied timeline (robots, n, 7): index 0
    where the arms stood, then every push's tail replacing the plan from its first waypoint."""
    timeline = None
    start = time.monotonic()
    for s, chunk in chunks(hands):
        time.sleep(max(0.0, start + (s - LEAD) * cell.step_time - time.monotonic()))
        pushed = cell.push(s, chunk)
        f = pushed["from"]
        if timeline is None:
            timeline = embodier.planned(0)
            assert f == 1
        else:
            timeline = np.concatenate([timeline[:, :f], embodier.planned(f)], axis=1)
        if on_push is not None:
            on_push(s, pushed)
    return timeline


def main(records, how="finish"):
    setup, hands = episode()
    e = omcbsa.Embodier(setup)
    announce = lambda s, p: print(f"pushed {s}", flush=True)  # noqa: E731
    if how == "exit":
        # Held by the module, so that only the interpreter's exit ends it (atexit).
        global CELL
        CELL = omcbsa.Cell(e, ARMS, time_scale=TIME_SCALE, records=records)
        replay(CELL, e, hands, on_push=announce)
        time.sleep(0.5)
        print("leaving", flush=True)
        return
    with omcbsa.Cell(e, ARMS, time_scale=TIME_SCALE, records=records) as cell:
        replay(cell, e, hands, on_push=announce)
        if how == "raise":
            time.sleep(0.5)
            raise RuntimeError("the policy failed")
        cell.finish()
    print("finished", flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])
