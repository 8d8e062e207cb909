"""Scheduling of a mock arm's process: a real arm's drives run on processors of their own, so a
mock that stands in for one on the host's machine must not wait behind the host's other work
(the planner, a build) or it answers late and the watchdog rightly stops the run.

`realtime()` asks for SCHED_FIFO at MOCK_PRIORITY: above every process at normal priority
(the planner, a build), below the executor's arm threads (50 by default), so that a mock's
work never holds up the loop it answers; refused (no CAP_SYS_NICE), it asks for nice -10, and
returns a line that says what the process runs under.

`background()` undoes it for the work a mock does once its run is over (writing its record: a
second or more of CPU for a long run). Under SCHED_FIFO that work would keep its core from every
mock at the same priority whose arm is still being stopped, and that mock would not answer the
host's stop in time.
"""

import os

# Below the executor's default SCHED_FIFO priority (ExecConfig::realtime_priority = 50), as
# the in-process simulators' threads (sim::SIM_PRIORITY).
MOCK_PRIORITY = 40


def realtime(priority=MOCK_PRIORITY):
    """Puts this process (and the threads it starts after) under SCHED_FIFO `priority`, or
    else at nice -10, or else leaves it; returns what it got, in words. OMCBSA_MOCK_SCHED=nice
    skips SCHED_FIFO (to compare)."""
    if os.environ.get("OMCBSA_MOCK_SCHED") == "nice":
        os.setpriority(os.PRIO_PROCESS, 0, -10)
        return "nice -10 (OMCBSA_MOCK_SCHED)"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        return "SCHED_FIFO %d" % priority
    except (PermissionError, AttributeError, OSError) as e:
        refused = "SCHED_FIFO %d refused (%s)" % (priority, e)
    try:
        os.setpriority(os.PRIO_PROCESS, 0, -10)
        return refused + "; nice -10"
    except (PermissionError, OSError):
        return refused + "; normal priority"


def background():
    """Puts the calling thread below every mock that still runs: SCHED_OTHER at nice 10."""
    try:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (PermissionError, AttributeError, OSError):
        pass
    try:
        os.setpriority(os.PRIO_PROCESS, 0, 10)
    except (PermissionError, OSError):
        pass
