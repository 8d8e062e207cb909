#!/usr/bin/env python3
"""Mock Kinova Gen3 arm for hardware-in-the-loop tests of the omcbsa executor.

Plays a Lawicel-compatible SLCAN adapter on a pseudo-terminal (the host opens the printed pty
path as its serial adapter) with seven CANopen CiA 402 drives behind it, node ids 1..7.

Each drive: NMT (start/stop/pre-operational), SDO expedited download (any object is accepted
and stored; 0x6040 drives the CiA 402 state machine, 0x1017 the heartbeat), RPDO1 = target
position (i32, 1e-7 rad per count) + controlword, applied at SYNC; TPDO1 = position actual +
statusword, sent at every SYNC; a first-order joint model; its own limit checks (Gen3 limits;
a violating command is refused, recorded and answered with an EMCY).

Every frame received from the host is recorded and written, as JSON lines, to --record at exit.
The mock exits when the host closes the pty (or after --max-seconds).

Fault injection: --stop-after-syncs N (go silent), --late-after-syncs N with --late-ms D (delay
every answer), --emcy-at-sync N (node 3 reports a fault), --lag-after-syncs N (joints stop
following their targets).
"""

import argparse
import errno
import json
import math
import os
import select
import signal
import sys
import time
import tty

import can

COUNTS_PER_RAD = 1e7
# Kinova Gen3: URDF position limits (None = continuous), joint_limits.yaml velocity/acceleration.
POSITION_LIMITS = [None, 2.24, None, 2.57, None, 2.09, None]
VELOCITY_LIMIT = 0.8727
ACCELERATION_LIMITS = [1.0, 1.0, 1.0, 1.0, 10.0, 10.0, 10.0]
# Float slack of the mock's own checks (the host's check is exact on the same counts).
SLACK = 1e-9

NMT_BOOTUP, NMT_STOPPED, NMT_OPERATIONAL, NMT_PRE_OPERATIONAL = 0x00, 0x04, 0x05, 0x7F
SW_SWITCH_ON_DISABLED, SW_READY, SW_SWITCHED_ON = 0x0040, 0x0021, 0x0023
SW_OPERATION_ENABLED, SW_QUICK_STOP, SW_FAULT = 0x0027, 0x0007, 0x0008
EMCY_EMCY_INJECTED = 0x2310  # continuous over-current
EMCY_COMMAND_REFUSED = 0x8A00  # position controller


class SlcanAdapterBus(can.BusABC):
    """The adapter end of SLCAN on a pty master: host commands in, bus frames out."""

    def __init__(self, fd, **kwargs):
        self.fd = fd
        self.inbuf = b""
        self.outbuf = b""
        self.channel_open = False
        self.connected = False
        super().__init__(channel="pty", **kwargs)

    def _reply(self, data):
        self.outbuf += data

    def _line(self, line):
        """Handles one host line; returns a received frame, if it was one."""
        if line[:1] == b"t" and self.channel_open:
            try:
                ident = int(line[1:4], 16)
                length = int(line[4:5])
                data = bytes.fromhex(line[5:].decode())
            except ValueError:
                data, length = None, -1
            if data is not None and len(data) == length <= 8:
                return can.Message(arbitration_id=ident, data=data, is_extended_id=False)
        elif line[:1] == b"O":
            self.channel_open = True
            self._reply(b"\r")
            return None
        elif line[:1] == b"C":
            was_open, self.channel_open = self.channel_open, False
            self._reply(b"\r" if was_open else b"\x07")
            return None
        elif line[:1] == b"S" and line[1:2] in b"012345678" and len(line) == 2:
            self._reply(b"\r")
            return None
        self._reply(b"\x07")
        return None

    def _recv_internal(self, timeout):
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            while b"\r" in self.inbuf:
                line, self.inbuf = self.inbuf.split(b"\r", 1)
                msg = self._line(line)
                if msg is not None:
                    return msg, False
            self.flush()
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            ready, _, _ = select.select([self.fd], [], [], left)
            if not ready:
                return None, False
            try:
                chunk = os.read(self.fd, 4096)
            except OSError as e:
                if e.errno != errno.EIO:
                    raise
                if self.connected:
                    raise EOFError("host closed the pty") from e
                # Nobody has opened the pty yet.
                time.sleep(0.005)
                if deadline is not None and time.monotonic() >= deadline:
                    return None, False
                continue
            self.connected = True
            self.inbuf += chunk

    def send(self, msg, timeout=None):
        if self.channel_open:
            self._reply(
                b"t%03X%d%s\r" % (msg.arbitration_id, len(msg.data), bytes(msg.data).hex().upper().encode())
            )

    def flush(self):
        while self.outbuf:
            n = os.write(self.fd, self.outbuf)
            self.outbuf = self.outbuf[n:]


class Drive:
    """One CiA 402 joint drive in cyclic synchronous position mode."""

    def __init__(self, joint, position):
        self.joint = joint
        self.node = joint + 1
        self.nmt = NMT_PRE_OPERATIONAL
        self.status = SW_SWITCH_ON_DISABLED
        self.position = position
        self.target = round(position * COUNTS_PER_RAD)
        self.history = [self.target, self.target]  # the two previous applied targets
        self.pending = None  # (counts, controlword) received since the last SYNC
        self.heartbeat_ms = 0
        self.next_heartbeat = 0.0
        self.objects = {}

    def controlword(self, cw):
        """CiA 402 state machine transitions of the commands the host uses."""
        if self.status == SW_FAULT:
            return
        if cw & 0x0F == 0x06:
            self.status = SW_READY
        elif cw & 0x0F == 0x07:
            self.status = SW_SWITCHED_ON
        elif cw & 0x0F == 0x0F and self.status in (SW_SWITCHED_ON, SW_OPERATION_ENABLED):
            if self.status != SW_OPERATION_ENABLED:
                self.target = round(self.position * COUNTS_PER_RAD)
                self.history = [self.target, self.target]
            self.status = SW_OPERATION_ENABLED
        elif cw & 0x06 == 0x02:
            self.status = SW_QUICK_STOP

    def check(self, counts, period):
        """The drive's own limits; returns the broken one, or None."""
        q = counts / COUNTS_PER_RAD
        bound = POSITION_LIMITS[self.joint]
        if bound is not None and abs(q) > bound + SLACK:
            return "position %.7f outside +-%s" % (q, bound)
        p1, p2 = self.history[1], self.history[0]
        v = (counts - p1) / COUNTS_PER_RAD / period
        if abs(v) > VELOCITY_LIMIT + SLACK:
            return "velocity %.4f above %s" % (v, VELOCITY_LIMIT)
        a = (counts - 2 * p1 + p2) / COUNTS_PER_RAD / period**2
        if abs(a) > ACCELERATION_LIMITS[self.joint] + SLACK:
            return "acceleration %.4f above %s" % (a, ACCELERATION_LIMITS[self.joint])
        return None


class MockArm:
    def __init__(self, args, bus):
        self.args = args
        self.bus = bus
        self.drives = [Drive(j, q) for j, q in enumerate(args.initial)]
        self.syncs = 0
        self.record = []
        self.delayed = []  # (due, message) while answering late
        self.t0 = time.monotonic()
        self.follow = 1.0 - math.exp(-args.period / args.tau)

    def log(self, **entry):
        entry["t"] = round(time.monotonic() - self.t0, 6)
        self.record.append(entry)

    def silent(self):
        n = self.args.stop_after_syncs
        return n is not None and self.syncs >= n

    def emit(self, ident, data):
        if self.silent():
            return
        msg = can.Message(arbitration_id=ident, data=data, is_extended_id=False)
        late = self.args.late_after_syncs
        if late is not None and self.syncs >= late:
            self.delayed.append((time.monotonic() + self.args.late_ms / 1000.0, msg))
        else:
            self.bus.send(msg)

    def emcy(self, drive, code):
        drive.status = SW_FAULT
        self.emit(0x80 + drive.node, code.to_bytes(2, "little") + bytes([0x01, 0, 0, 0, 0, 0]))

    def nodes(self, node):
        return self.drives if node == 0 else [d for d in self.drives if d.node == node]

    def handle(self, msg):
        ident, data = msg.arbitration_id, bytes(msg.data)
        if ident == 0x000 and len(data) == 2:
            self.log(kind="nmt", command=data[0], node=data[1])
            state = {0x01: NMT_OPERATIONAL, 0x02: NMT_STOPPED, 0x80: NMT_PRE_OPERATIONAL}.get(data[0])
            for d in self.nodes(data[1]):
                d.nmt = state if state is not None else NMT_PRE_OPERATIONAL
        elif ident == 0x080 and not data:
            self.sync()
        elif 0x601 <= ident <= 0x607 and len(data) == 8:
            self.sdo(self.drives[ident - 0x601], data)
        elif 0x201 <= ident <= 0x207 and len(data) == 6:
            d = self.drives[ident - 0x201]
            counts = int.from_bytes(data[0:4], "little", signed=True)
            cw = int.from_bytes(data[4:6], "little")
            self.log(kind="rpdo", node=d.node, sync=self.syncs, counts=counts, cw=cw, nmt=d.nmt)
            if d.nmt == NMT_OPERATIONAL:
                d.pending = (counts, cw)
        else:
            self.log(kind="other", id=ident, data=data.hex())

    def sdo(self, d, data):
        index, sub = int.from_bytes(data[1:3], "little"), data[3]
        if data[0] & 0xE3 != 0x23:  # only expedited download with size indicated
            self.log(kind="sdo", node=d.node, index=index, sub=sub, refused=True)
            self.emit(0x580 + d.node, bytes([0x80]) + data[1:4] + (0x05040001).to_bytes(4, "little"))
            return
        size = 4 - ((data[0] >> 2) & 0x03)
        value = int.from_bytes(data[4 : 4 + size], "little")
        self.log(kind="sdo", node=d.node, index=index, sub=sub, value=value)
        d.objects[(index, sub)] = value
        if index == 0x6040:
            d.controlword(value)
        elif index == 0x1017:
            d.heartbeat_ms = value
            d.next_heartbeat = time.monotonic()
        self.emit(0x580 + d.node, bytes([0x60]) + data[1:4] + bytes(4))

    def sync(self):
        self.syncs += 1
        self.log(kind="sync", n=self.syncs)
        lagging = self.args.lag_after_syncs is not None and self.syncs >= self.args.lag_after_syncs
        for d in self.drives:
            if d.nmt != NMT_OPERATIONAL:
                continue
            if d.pending is not None:
                counts, cw = d.pending
                d.pending = None
                d.controlword(cw)
                if d.status == SW_OPERATION_ENABLED:
                    broken = d.check(counts, self.args.period)
                    if broken:
                        self.log(kind="violation", node=d.node, sync=self.syncs, counts=counts, what=broken)
                        self.emcy(d, EMCY_COMMAND_REFUSED)
                    else:
                        d.history = [d.history[1], counts]
                        d.target = counts
            if d.status == SW_OPERATION_ENABLED and not lagging:
                d.position += (d.target / COUNTS_PER_RAD - d.position) * self.follow
            if self.args.emcy_at_sync == self.syncs and d.node == 3:
                self.emcy(d, EMCY_EMCY_INJECTED)
            counts = round(d.position * COUNTS_PER_RAD)
            self.emit(0x180 + d.node, counts.to_bytes(4, "little", signed=True) + d.status.to_bytes(2, "little"))

    def housekeeping(self):
        """Heartbeats and late answers that are due; returns the time until the next one."""
        now = time.monotonic()
        due = [m for t, m in self.delayed if t <= now]
        self.delayed = [(t, m) for t, m in self.delayed if t > now]
        for m in due:
            self.bus.send(m)
        nxt = 0.05
        for d in self.drives:
            if d.heartbeat_ms > 0:
                if now >= d.next_heartbeat:
                    self.emit(0x700 + d.node, bytes([d.nmt]))
                    d.next_heartbeat = now + d.heartbeat_ms / 1000.0
                nxt = min(nxt, d.next_heartbeat - now)
        if self.delayed:
            nxt = min(nxt, self.delayed[0][0] - now)
        self.bus.flush()
        return max(nxt, 0.0)

    def run(self):
        deadline = self.t0 + self.args.max_seconds
        booted = False
        while time.monotonic() < deadline:
            msg = self.bus.recv(timeout=self.housekeeping())
            if not booted and self.bus.channel_open:
                booted = True
                for d in self.drives:
                    self.emit(0x700 + d.node, bytes([NMT_BOOTUP]))
            if msg is not None:
                self.handle(msg)

    def write_record(self):
        if self.args.record:
            with open(self.args.record, "w") as f:
                for entry in self.record:
                    f.write(json.dumps(entry) + "\n")


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--initial", default="0,0,0,0,0,0,0", help="7 joint positions at power-on, rad, comma separated")
    p.add_argument("--period", type=float, default=0.002, help="control period for the limit checks, s")
    p.add_argument("--tau", type=float, default=0.004, help="time constant of the joint model, s")
    p.add_argument("--record", help="write every received command here (JSON lines) at exit")
    p.add_argument("--max-seconds", type=float, default=60.0, help="exit after this long in any case")
    p.add_argument("--stop-after-syncs", type=int, help="go silent after this many SYNCs")
    p.add_argument("--late-after-syncs", type=int, help="delay every answer after this many SYNCs")
    p.add_argument("--late-ms", type=float, default=200.0, help="delay of late answers, ms")
    p.add_argument("--emcy-at-sync", type=int, help="node 3 sends an EMCY and faults at this SYNC")
    p.add_argument("--lag-after-syncs", type=int, help="joints stop following after this many SYNCs")
    args = p.parse_args(argv)
    try:
        args.initial = [float(x) for x in args.initial.split(",")]
    except ValueError:
        p.error("--initial: expected 7 comma-separated numbers, got %r" % args.initial)
    if len(args.initial) != 7:
        p.error("--initial: expected 7 joint positions, got %d" % len(args.initial))
    if args.period <= 0 or args.tau <= 0:
        p.error("--period and --tau must be positive")
    return args


def main(argv):
    args = parse_args(argv)
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    # Only the host keeps the slave open, so that its closing shows here as EIO.
    os.close(slave)
    bus = SlcanAdapterBus(master)
    arm = MockArm(args, bus)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    print("PTY " + path, flush=True)
    try:
        arm.run()
    except EOFError:
        pass
    finally:
        arm.write_record()
        bus.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
