"""A mock's bus log (a candump log, python-can's writer) that never makes the drives wait for
the disk.

A write to a file can block for tens of milliseconds while the kernel flushes other processes'
dirty pages (a release build just before the run, on a slow disk). In the drives' thread that
is an answer two periods late, which the host's watchdog rightly takes for a fault. A second
thread would not do: it would hold the interpreter lock while the drives wait for it, at a
lower priority than theirs. So the drives' thread formats the lines when it has caught up
with the host (a little at a time, as before) and hands them to a `cat` process at normal
priority through a pipe it never blocks on; `cat` waits for the disk instead. What the pipe
cannot take yet stays in memory until it can.

Costs: the frames not yet formatted and the bytes the pipe has not taken, in memory; a
process.
"""

import io
import os
import subprocess
import time

import can

import drive_clock


class BusLog:
    """Frames handed over by `add`, formatted by `write_some` and written to `path` by a
    `cat` process; `close` writes the rest and waits for it."""

    def __init__(self, path):
        self.out = open(path, "wb")
        self.cat = subprocess.Popen(["cat"], stdin=subprocess.PIPE, stdout=self.out,
                                    preexec_fn=drive_clock.background)
        os.set_blocking(self.cat.stdin.fileno(), False)
        self.text = io.StringIO()
        self.writer = can.CanutilsLogWriter(self.text, channel="can0")
        self.pending = []  # (time, id, data, from host?)
        self.unsent = b""

    def add(self, t, ident, data, rx):
        self.pending.append((t, ident, data, rx))

    def write_some(self, budget=None):
        """Formats pending frames for at most `budget` seconds (all without one) and passes
        what the pipe takes."""
        end = None if budget is None else time.monotonic() + budget
        done = 0
        for t, ident, data, rx in self.pending:
            self.writer.on_message_received(can.Message(
                timestamp=t, arbitration_id=ident, data=data, is_extended_id=False, is_rx=rx))
            done += 1
            if end is not None and done % 8 == 0 and time.monotonic() >= end:
                break
        del self.pending[:done]
        self.unsent += self.text.getvalue().encode()
        self.text.seek(0)
        self.text.truncate()
        try:
            n = os.write(self.cat.stdin.fileno(), self.unsent) if self.unsent else 0
        except BlockingIOError:
            n = 0
        self.unsent = self.unsent[n:]

    def close(self):
        """Writes the rest, waiting for the pipe, and waits for `cat`."""
        self.write_some()
        os.set_blocking(self.cat.stdin.fileno(), True)
        self.cat.stdin.write(self.unsent)
        self.cat.stdin.close()
        self.cat.wait()
        self.out.close()
