#!/usr/bin/env python3
"""Mock Kinova Gen3 arm for hardware-in-the-loop tests of the omcbsa executor.

Plays a Lawicel-compatible SLCAN adapter on a Unix socket (the host connects to the printed
socket path as its adapter's serial line) with seven CiA 402 joint drives behind it, node ids
1..7. A socket rather than a pseudo-terminal: a pty's bytes cross the kernel in a worker thread
that a loaded machine delays by tens of milliseconds, which the host's watchdog rightly takes
for a drive that stopped answering.

Each drive is a node of the `canopen` library (CiA 301): a LocalNode whose object dictionary is
loaded from gen3_joint_drive.eds. The library answers SDO requests (and aborts those the object
dictionary refuses: unknown object, read-only, wrong size), decodes the RPDOs and encodes the
TPDOs with the mapping the host wrote, follows NMT commands, and produces boot-up, heartbeat and
EMCY messages. This file adds what the library leaves to the application: the checks a drive
makes on its PDO configuration (CiA 301: mapping only while the PDO is invalid, mappable objects
of the right size, at most 64 bits), the CiA 402 state machine in cyclic synchronous position
mode, the joint model (first order in time, --tau: the joint moves toward its target between
SYNCs too, and a TPDO reports where it got to by its SYNC), and the drive's own limit checks
(Gen3 position limits in 0x607D, velocity and acceleration over the interpolation period 0x60C2;
a violating command is refused, recorded and answered with an EMCY), and its following-error
monitoring as CiA 402 has
it (|target - actual| beyond the window 0x6065 for the time-out 0x6066: statusword bit 13, fault,
EMCY 0x8611).

Every frame received from the host is recorded and written, as JSON lines, to --record at exit;
--bus-log writes every frame in both directions as a candump log (python-can's writer; R = from
the host, T = from the drives). The mock exits when the host closes its connection (or after
--max-seconds).

Fault injection (all on node 3 unless said otherwise): --stop-after-syncs N (every drive goes
silent), --late-after-syncs N with --late-ms D (every answer delayed), --emcy-at-sync N (EMCY and
fault), --fault-at-sync N (statusword fault bit, no EMCY), --nmt-stop-at-sync N (the node leaves
operational for stopped), --heartbeat-stop-at-sync N (the node stops its heartbeat),
--lag-after-syncs N (every joint stops following its target; the drives' following-error
monitoring faults them).
"""

import argparse
import gc
import json
import math
import os
import select
import signal
import socket
import sys
import tempfile
import threading
import time

import can
import canopen
from canopen.sdo import SdoAbortedError

import drive_clock
from bus_log import BusLog

EDS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "gen3_joint_drive.eds")
COUNTS_PER_RAD = 1e7
# Kinova Gen3: URDF position limits (None = continuous), joint_limits.yaml velocity/acceleration.
POSITION_LIMITS = [None, 2.24, None, 2.57, None, 2.09, None]
VELOCITY_LIMIT = 0.8727
ACCELERATION_LIMITS = [1.0, 1.0, 1.0, 1.0, 10.0, 10.0, 10.0]
# Float slack of the mock's own checks (the host's check is exact on the same counts).
SLACK = 1e-9
FAULTY_NODE = 3
# Longest the bus log's lines are formatted for at a time while the host streams, s.
LOG_BUDGET = 0.0005

MODE_CSP = 8
SYNC_ID = 0x080

# SDO abort codes (CiA 301) the library does not raise itself.
ABORT_CANNOT_MAP = 0x06040041
ABORT_PDO_TOO_LONG = 0x06040042
ABORT_INVALID_VALUE = 0x06090030
ABORT_VALUE_TOO_HIGH = 0x06090031
ABORT_VALUE_TOO_LOW = 0x06090032
ABORT_DEVICE_STATE = 0x08000022

EMCY_INJECTED = 0x2310  # continuous over-current
EMCY_REFERENCE_LIMIT = 0x8612  # a command beyond the drive's limits
EMCY_PDO_LENGTH = 0x8210  # PDO not processed: length error
EMCY_FOLLOWING_ERROR = 0x8611  # CiA 402: following error
SW_FOLLOWING_ERROR = 0x2000  # statusword bit 13 in cyclic synchronous position mode
FOLLOWING_ERROR_OFF = 0xFFFFFFFF  # a window of 0xFFFFFFFF switches the check off

# CiA 402 states: statusword value (bits 0-6, with "voltage enabled" and "quick stop" as a drive
# reports them).
SWITCH_ON_DISABLED, READY, SWITCHED_ON = 0x0040, 0x0031, 0x0033
OPERATION_ENABLED, QUICK_STOP_ACTIVE, FAULT = 0x0037, 0x0017, 0x0008
REMOTE = 0x0200  # statusword bit 9: controlled over the bus


class MainLoopTask(can.broadcastmanager.ModifiableCyclicTaskABC):
    """A periodic frame (a drive's heartbeat) sent by the adapter's main loop when due, not by a
    thread of its own: with every thread of the mock under SCHED_FIFO, eight threads handing the
    interpreter lock to each other stalled the drives' answers for tens of milliseconds; a
    drive's firmware sends its heartbeat from its one loop too."""

    def __init__(self, bus, messages, period):
        super().__init__(messages, period)
        self.bus = bus
        self.due = time.monotonic()
        self.stopped = False

    def stop(self):
        self.stopped = True

    def send_if_due(self, now):
        """Sends the frame if it is due; returns the time of the next one."""
        if now >= self.due:
            self.bus.send(self.messages[0])
            # No bursts after a stall: the next one a period from now at the latest.
            self.due = max(self.due + self.period, now)
        return self.due


class SlcanAdapterBus(can.BusABC):
    """The adapter end of SLCAN on a connected socket: host commands in, bus frames out.

    Sending is thread-safe (the library's heartbeats come from their own threads). Every frame is
    handed to `log` (a bus_log.BusLog) if given, and formatted when the mock has caught up
    with the host;
    `silent` drops what the drives send and `delay` holds it back that many seconds (fault
    injection)."""

    def __init__(self, fd, log=None, **kwargs):
        self.fd = fd
        self.log = log
        self.inbuf = b""
        self.channel_open = False
        self.silent = False
        self.delay = 0.0
        self.delayed = []  # (due, message), in order
        self.periodic = []  # MainLoopTask, sent by send_due
        self.lock = threading.Lock()
        super().__init__(channel="slcan-socket", **kwargs)

    def _reply(self, data):
        with self.lock:
            self._write(data)

    def _write(self, data):
        while data:
            try:
                n = os.write(self.fd, data)
            except (BrokenPipeError, ConnectionResetError) as e:
                raise EOFError("the host closed the connection") from e
            data = data[n:]

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
                msg = can.Message(timestamp=time.time(), arbitration_id=ident, data=data, is_extended_id=False)
                self._log(msg.timestamp, ident, data, True)
                return msg
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

    def _log(self, t, ident, data, rx):
        if self.log is not None:
            self.log.add(t, ident, data, rx)

    def _recv_internal(self, timeout):
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            while b"\r" in self.inbuf:
                line, self.inbuf = self.inbuf.split(b"\r", 1)
                msg = self._line(line)
                if msg is not None:
                    return msg, False
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            ready, _, _ = select.select([self.fd], [], [], 0)
            if not ready:
                if self.log is not None:
                    # caught up with the host: time to log, a little at a time
                    self.log.write_some(LOG_BUDGET)
                ready, _, _ = select.select([self.fd], [], [], left)
            if not ready:
                return None, False
            try:
                chunk = os.read(self.fd, 4096)
            except ConnectionResetError as e:
                raise EOFError("the host closed the connection") from e
            if not chunk:
                raise EOFError("the host closed the connection")
            self.inbuf += chunk

    def send(self, msg, timeout=None):
        with self.lock:
            if not self.channel_open or self.silent:
                return
            if self.delay > 0:
                self.delayed.append((time.monotonic() + self.delay, msg))
                return
            try:
                self._transmit(msg)
            except EOFError:
                # The host has gone (the library's heartbeat threads send too): nothing more
                # goes out; the main thread sees the end when it next reads.
                self.channel_open = False

    def _transmit(self, msg):
        # The caller holds the lock.
        data = bytes(msg.data)
        if self.log is not None:
            self.log.add(time.time(), msg.arbitration_id, data, False)
        self._write(b"t%03X%d%s\r" % (msg.arbitration_id, len(data), data.hex().upper().encode()))

    def _send_periodic_internal(self, msgs, period, duration=None, autostart=True,
                                modifier_callback=None):
        task = MainLoopTask(self, msgs, period)
        self.periodic.append(task)
        return task

    def send_due(self):
        """Sends the held-back and periodic frames that are due; returns the time until the next
        one."""
        with self.lock:
            now = time.monotonic()
            while self.delayed and self.delayed[0][0] <= now:
                self._transmit(self.delayed.pop(0)[1])
            nxt = [self.delayed[0][0]] if self.delayed else []
        self.periodic = [t for t in self.periodic if not t.stopped]
        nxt += [t.send_if_due(now) for t in self.periodic]
        return max(0.0, min(nxt) - time.monotonic()) if nxt else None


class Drive:
    """One CiA 402 joint drive in cyclic synchronous position mode, on a canopen LocalNode."""

    def __init__(self, arm, joint, position):
        self.arm = arm
        self.joint = joint
        self.node = canopen.LocalNode(joint + 1, EDS)
        self.od = self.node.object_dictionary
        self.entries = {}
        arm.network.add_node(self.node)
        self.node.add_write_callback(self.on_write)
        self.node.add_read_callback(self.on_read)
        self.rpdo, self.tpdo = self.node.rpdo.map[1], self.node.tpdo.map[1]
        # The objects whose writes this drive checks or acts on (the library stores the rest).
        self.writes = {
            0x1005: self.write_sync_id,
            0x1400: lambda sub, v: self.write_pdo_comm(0x1400, sub, v),
            0x1800: lambda sub, v: self.write_pdo_comm(0x1800, sub, v),
            0x1600: lambda sub, v: self.write_pdo_mapping(True, 0x1400, 0x1600, sub, v),
            0x1A00: lambda sub, v: self.write_pdo_mapping(False, 0x1800, 0x1A00, sub, v),
            0x6040: lambda sub, v: self.controlword(v),
            0x6060: lambda sub, v: self.write_mode(v),
            0x607D: self.write_parameter,
            0x60C2: self.write_parameter,
            0x6065: self.write_parameter,
            0x6066: self.write_parameter,
        }
        # (mode, interpolation period s, (min, max) counts, (following error window counts,
        # time-out s)) from the OD
        self.params = None
        self.state = SWITCH_ON_DISABLED
        self.position = position
        self.moved_at = time.monotonic()  # when `position` was last brought up to date
        self.target = round(position * COUNTS_PER_RAD)
        self.history = [self.target, self.target]  # the two previous applied targets
        self.new_target = None  # the target (counts) applied since the last SYNC
        self.pending = None  # a synchronous RPDO's values, applied at the next SYNC
        self.beyond_since = None  # the SYNC from which |target - actual| is beyond the window
        self.following_error = False
        self.syncs_since_tpdo = 0
        self.last_tpdo = None
        self.pdo_stale = True
        self.sync_id = None
        bound = POSITION_LIMITS[joint]
        if bound is not None:
            self.put(0x607D, round(-bound * COUNTS_PER_RAD), 1)
            self.put(0x607D, round(bound * COUNTS_PER_RAD), 2)
        self.rpdo.add_callback(self.on_rpdo)
        self.subscribe_sync()

    @property
    def id(self):
        return self.node.id

    def entry(self, index, sub=0):
        """The OD entry of (index, sub); KeyError if there is none."""
        key = (index, sub)
        if key not in self.entries:
            obj = self.od[index]
            self.entries[key] = obj if isinstance(obj, canopen.objectdictionary.ODVariable) else obj[sub]
        return self.entries[key]

    def get(self, index, sub=0):
        return self.entry(index, sub).decode_raw(self.node.get_data(index, sub))

    def put(self, index, value, sub=0):
        self.node.set_data(index, sub, self.entry(index, sub).encode_raw(value))

    def operational(self):
        return self.node.nmt.state == "OPERATIONAL"

    def statusword(self):
        word = self.state | (REMOTE if self.state != FAULT else 0)
        return word | (SW_FOLLOWING_ERROR if self.following_error else 0)

    def parameters(self):
        """Mode of operation in effect, interpolation period (0x60C2) in seconds, software
        position limits (0x607D) in counts, following error window (0x6065, counts) and time-out
        (0x6066, in seconds); read from the OD after a write to them."""
        if self.params is None:
            period = self.get(0x60C2, 1) * 10.0 ** self.get(0x60C2, 2)
            self.params = (self.get(0x6061), period, (self.get(0x607D, 1), self.get(0x607D, 2)),
                           (self.get(0x6065), self.get(0x6066) / 1000.0))
        return self.params

    def on_read(self, index, subindex, od):
        """The live values: statusword and position actual (SDO reads and TPDOs)."""
        if index == 0x6041:
            return self.statusword()
        if index == 0x6064:
            self.advance()
            return round(self.position * COUNTS_PER_RAD)
        return None

    # --- object dictionary writes (SDO from the host, or RPDO values applied) ---

    def on_write(self, index, subindex, od, data):
        """Checks and side effects of a write, before the library stores it. Raising
        SdoAbortedError makes the library abort the SDO transfer with that code."""
        write = self.writes.get(index)
        if write is None:
            return
        value = od.decode_raw(data)
        if od.max is not None and value > od.max:
            raise SdoAbortedError(ABORT_VALUE_TOO_HIGH)
        if od.min is not None and value < od.min:
            raise SdoAbortedError(ABORT_VALUE_TOO_LOW)
        write(subindex, value)

    def write_parameter(self, sub, value):
        self.params = None

    def write_mode(self, value):
        if value not in (0, MODE_CSP):
            raise SdoAbortedError(ABORT_INVALID_VALUE)
        self.put(0x6061, value)
        self.params = None

    def write_sync_id(self, sub, value):
        if value & 0x7FFFF800:
            # this drive consumes SYNC (bit 30 clear) on an 11-bit identifier only
            raise SdoAbortedError(ABORT_INVALID_VALUE)
        self.pdo_stale = True

    def pdo_valid(self, comm):
        return self.get(comm, 1) & 0x80000000 == 0

    def write_pdo_comm(self, comm, sub, value):
        self.pdo_stale = True
        if sub == 1:
            if value & 0x3FFFF800:
                raise SdoAbortedError(ABORT_INVALID_VALUE)  # 11-bit identifiers only
            old = self.get(comm, 1)
            if value & 0x80000000 == 0 and old & 0x80000000 == 0 and value & 0x7FF != old & 0x7FF:
                # CiA 301: the COB-ID of a valid PDO cannot change
                raise SdoAbortedError(ABORT_INVALID_VALUE)
        elif sub == 2:
            if not (value <= 240 or value in (254, 255)):
                raise SdoAbortedError(ABORT_INVALID_VALUE)

    def write_pdo_mapping(self, receive, comm, mapping, sub, value):
        """CiA 301 procedure: the mapping changes only while the PDO is invalid, entries only
        while sub 0 is 0; an entry names a mappable object of that size (writable for an RPDO,
        readable for a TPDO); the entries counted by sub 0 fit in 64 bits."""
        self.pdo_stale = True
        if self.pdo_valid(comm):
            raise SdoAbortedError(ABORT_DEVICE_STATE)
        if sub == 0:
            if value > 8:
                raise SdoAbortedError(ABORT_VALUE_TOO_HIGH)
            bits = 0
            for s in range(1, value + 1):
                bits += self.mapped_size(receive, self.get(mapping, s))
            if bits > 64:
                raise SdoAbortedError(ABORT_PDO_TOO_LONG)
        else:
            if self.get(mapping, 0) != 0:
                raise SdoAbortedError(ABORT_DEVICE_STATE)
            if value != 0:
                self.mapped_size(receive, value)

    def mapped_size(self, receive, entry):
        index, sub, bits = entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF
        try:
            od = self.entry(index, sub)
        except KeyError:
            raise SdoAbortedError(ABORT_CANNOT_MAP) from None
        access = od.writable if receive else od.readable
        if not od.pdo_mappable or not access or bits != len(od):
            raise SdoAbortedError(ABORT_CANNOT_MAP)
        return bits

    def controlword(self, cw):
        """CiA 402 state machine: the transitions the controlword commands."""
        s = self.state
        if s == FAULT:
            if cw & 0x80:  # fault reset
                self.state = SWITCH_ON_DISABLED
                self.following_error = False
        elif cw & 0x02 == 0:  # disable voltage
            self.state = SWITCH_ON_DISABLED
        elif cw & 0x04 == 0:  # quick stop
            self.state = QUICK_STOP_ACTIVE if s in (OPERATION_ENABLED, QUICK_STOP_ACTIVE) else SWITCH_ON_DISABLED
        elif cw & 0x0F == 0x06:  # shutdown
            if s in (SWITCH_ON_DISABLED, SWITCHED_ON, OPERATION_ENABLED):
                self.state = READY
        elif cw & 0x0F == 0x07:  # switch on / disable operation
            if s in (READY, OPERATION_ENABLED):
                self.state = SWITCHED_ON
        elif cw & 0x0F == 0x0F:  # enable operation
            if s in (SWITCHED_ON, QUICK_STOP_ACTIVE):
                # CSP holds where the joint is until the first new target
                self.advance()
                self.target = round(self.position * COUNTS_PER_RAD)
                self.history = [self.target, self.target]
                self.put(0x607A, self.target)
                self.beyond_since = None
                self.state = OPERATION_ENABLED

    def fault(self, code=None):
        self.state = FAULT
        if code is not None:
            self.put(0x1001, 0x01)  # generic error
            self.node.emcy.send(code, 0x01)

    # --- PDOs and SYNC ---

    def refresh(self):
        """Re-reads the PDO configuration the host wrote (the library decodes and encodes the
        PDOs with it) and the SYNC COB-ID, after a write to them."""
        if not self.pdo_stale:
            return
        self.pdo_stale = False
        for pdo in (self.rpdo, self.tpdo):
            if pdo.enabled and pdo.cob_id in self.arm.network.subscribers:
                try:
                    self.arm.network.unsubscribe(pdo.cob_id, pdo.on_message)
                except ValueError:
                    pass
            pdo.read()
        self.last_tpdo = None
        self.subscribe_sync()

    def subscribe_sync(self):
        sync_id = self.get(0x1005) & 0x7FF
        if sync_id != self.sync_id:
            if self.sync_id is not None:
                self.arm.network.unsubscribe(self.sync_id, self.on_sync)
            self.arm.network.subscribe(sync_id, self.on_sync)
            self.sync_id = sync_id

    def on_rpdo(self, pdo):
        """An RPDO, decoded with the mapping the host wrote."""
        data = bytes(pdo.data)
        if len(data) * 8 < pdo.length:
            self.arm.log(kind="pdo_length", node=self.id, sync=self.arm.syncs, data=data.hex())
            if self.operational():
                self.node.emcy.send(EMCY_PDO_LENGTH, 0x01)
            return
        values = [(var.index, var.subindex, var.get_data()) for var in pdo.map]
        decoded = {(i, s): self.entry(i, s).decode_raw(d) for i, s, d in values}
        self.arm.log(
            kind="rpdo", node=self.id, sync=self.arm.syncs, counts=decoded.get((0x607A, 0)),
            cw=decoded.get((0x6040, 0)), nmt=self.node.nmt.state,
        )
        if not self.operational():
            return
        if pdo.trans_type is not None and pdo.trans_type <= 240:
            self.pending = (values, decoded)
        else:
            self.apply(values, decoded)

    def apply(self, values, decoded):
        """Stores an RPDO's values in the OD (a controlword takes effect)."""
        for index, sub, data in values:
            self.node.set_data(index, sub, data)
        if (0x607A, 0) in decoded:
            self.new_target = decoded[(0x607A, 0)]

    def advance(self):
        """The joint model, first order in time: in operation enabled (and not lagging by
        injection) the joint moves toward its target with the time constant --tau, between
        SYNCs too; in any other state it holds."""
        now = time.monotonic()
        dt, self.moved_at = now - self.moved_at, now
        if self.state == OPERATION_ENABLED and not self.arm.lagging():
            k = 1.0 - math.exp(-dt / self.arm.args.tau)
            self.position += (self.target / COUNTS_PER_RAD - self.position) * k

    def on_sync(self, can_id, data, timestamp):
        if not self.operational():
            return
        # Where the joint got to, following the last target, by this SYNC: what the TPDO
        # reports; the new target applies from here on.
        self.advance()
        if self.pending is not None:
            self.apply(*self.pending)
            self.pending = None
        arm = self.arm
        mode, period, limits, following = self.parameters()
        counts = self.new_target
        if self.state == OPERATION_ENABLED and counts is not None and mode == MODE_CSP:
            broken = self.check(counts, period, limits)
            if broken:
                arm.log(kind="violation", node=self.id, sync=arm.syncs, counts=counts, what=broken)
                self.fault(EMCY_REFERENCE_LIMIT)
            else:
                self.history = [self.history[1], counts]
                self.target = counts
        self.new_target = None
        if self.state == OPERATION_ENABLED and mode == MODE_CSP:
            self.watch_following_error(period, *following)
        if self.id == FAULTY_NODE:
            self.inject(arm.syncs)
        self.transmit_tpdo()

    def watch_following_error(self, period, window, time_out):
        """CiA 402 following error: |target - actual| beyond the window (0x6065, counts) for at
        least the time-out (0x6066, ms), timed on the drive's own clock (its SYNCs), sets
        statusword bit 13 and faults with EMCY 0x8611."""
        error = abs(self.target - round(self.position * COUNTS_PER_RAD))
        if window == FOLLOWING_ERROR_OFF or error <= window:
            self.beyond_since = None
            return
        syncs = self.arm.syncs
        if self.beyond_since is None:
            self.beyond_since = syncs
        if (syncs - self.beyond_since) * period >= time_out:
            self.arm.log(kind="following_error", node=self.id, sync=syncs, error=error, window=window)
            self.following_error = True
            self.fault(EMCY_FOLLOWING_ERROR)

    def inject(self, sync):
        args = self.arm.args
        if args.emcy_at_sync == sync:
            self.fault(EMCY_INJECTED)
        if args.fault_at_sync == sync:
            self.fault()
        if args.heartbeat_stop_at_sync == sync:
            self.node.nmt.stop_heartbeat()
        if args.nmt_stop_at_sync == sync:
            self.node.nmt.state = "STOPPED"
            # announce the new state at once rather than at the next heartbeat
            self.node.nmt.start_heartbeat(self.get(0x1017))

    def transmit_tpdo(self):
        """TPDO1 per its transmission type: every n-th SYNC, or (254/255) when its data changed."""
        pdo = self.tpdo
        if not pdo.enabled or not self.operational():
            return
        for var in pdo.map:
            var.set_data(self.node.get_data(var.index, var.subindex))
        self.syncs_since_tpdo += 1
        t = pdo.trans_type
        if 1 <= t <= 240:
            due = self.syncs_since_tpdo >= t
        else:
            due = bytes(pdo.data) != self.last_tpdo
        if due:
            self.syncs_since_tpdo = 0
            self.last_tpdo = bytes(pdo.data)
            pdo.transmit()

    def check(self, counts, period, limits):
        """The drive's own limits; returns the broken one, or None."""
        lo, hi = limits
        if not lo <= counts <= hi:
            return "position %.7f outside the software limits [%.7f, %.7f] (0x607D)" % (
                counts / COUNTS_PER_RAD, lo / COUNTS_PER_RAD, hi / COUNTS_PER_RAD)
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
        self.network = canopen.Network(bus)
        self.syncs = 0
        self.record = []
        self.t0 = time.monotonic()
        self.drives = [Drive(self, j, q) for j, q in enumerate(args.initial)]
        self.disturb_bus()

    def log(self, **entry):
        entry["t"] = round(time.monotonic() - self.t0, 6)
        self.record.append(entry)

    def disturb_bus(self):
        """Silence or delay the drives once the SYNC count asks for it."""
        a = self.args
        self.bus.silent = a.stop_after_syncs is not None and self.syncs >= a.stop_after_syncs
        if a.late_after_syncs is not None and self.syncs >= a.late_after_syncs:
            self.bus.delay = a.late_ms / 1000.0

    def lagging(self):
        n = self.args.lag_after_syncs
        return n is not None and self.syncs >= n

    def boot(self):
        """Power-on: every node sends its boot-up message and enters pre-operational."""
        for d in self.drives:
            d.node.nmt.send_command(0x81)  # reset node: boot-up message
            d.node.nmt.send_command(0x80)  # enter pre-operational

    def handle(self, msg):
        ident, data = msg.arbitration_id, bytes(msg.data)
        if ident == 0x000 and len(data) == 2:
            self.log(kind="nmt", command=data[0], node=data[1])
        elif ident == SYNC_ID and not data:
            self.syncs += 1
            self.log(kind="sync", n=self.syncs)
            self.disturb_bus()
        elif 0x601 <= ident <= 0x67F and len(data) == 8:
            self.log(kind="sdo", node=ident - 0x600, command=data[0],
                     index=int.from_bytes(data[1:3], "little"), sub=data[3], data=data[4:].hex())
        elif ident not in self.network.subscribers:
            self.log(kind="other", id=ident, data=data.hex())
        self.network.notify(ident, data, msg.timestamp)
        if 0x600 < ident < 0x680:
            for d in self.drives:
                d.refresh()
        if ident == 0x000 and len(data) == 2:
            self.announce_state(data[1])

    def announce_state(self, node):
        """Each drive an NMT command addressed (`node`: its id, or 0 for all) reports its new
        state at once by heartbeat, as CANopenNode-based drives do, rather than at its next
        period: the host confirms a stop by it."""
        for d in self.drives:
            # A drive whose heartbeat was stopped (fault injection) stays silent.
            if node in (0, d.id) and getattr(d.node.nmt, "_send_task", None) is not None:
                self.bus.send(can.Message(arbitration_id=0x700 + d.id, data=[d.node.nmt._state],
                                          is_extended_id=False))

    def run(self):
        deadline = self.t0 + self.args.max_seconds
        booted = False
        while time.monotonic() < deadline:
            due = self.bus.send_due()
            msg = self.bus.recv(timeout=0.05 if due is None else min(0.05, due))
            if not booted and self.bus.channel_open:
                booted = True
                self.boot()
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
    p.add_argument("--tau", type=float, default=0.004, help="time constant of the joint model, s")
    p.add_argument("--record", help="write every received command here (JSON lines) at exit")
    p.add_argument("--bus-log", help="write every frame, both directions, here (candump log)")
    p.add_argument("--max-seconds", type=float, default=60.0, help="exit after this long in any case")
    p.add_argument("--stop-after-syncs", type=int, help="go silent after this many SYNCs")
    p.add_argument("--late-after-syncs", type=int, help="delay every answer after this many SYNCs")
    p.add_argument("--late-ms", type=float, default=200.0, help="delay of late answers, ms")
    p.add_argument("--emcy-at-sync", type=int, help="node 3 sends an EMCY and faults at this SYNC")
    p.add_argument("--fault-at-sync", type=int, help="node 3 faults (statusword) at this SYNC, no EMCY")
    p.add_argument("--nmt-stop-at-sync", type=int, help="node 3 goes to NMT stopped at this SYNC")
    p.add_argument("--heartbeat-stop-at-sync", type=int, help="node 3 stops its heartbeat at this SYNC")
    p.add_argument("--lag-after-syncs", type=int, help="joints stop following after this many SYNCs")
    args = p.parse_args(argv)
    try:
        args.initial = [float(x) for x in args.initial.split(",")]
    except ValueError:
        p.error("--initial: expected 7 comma-separated numbers, got %r" % args.initial)
    if len(args.initial) != 7:
        p.error("--initial: expected 7 joint positions, got %d" % len(args.initial))
    if args.tau <= 0:
        p.error("--tau must be positive")
    return args


def main(argv):
    args = parse_args(argv)
    # Real drives have processors of their own: the mock must not wait behind the host's work.
    sched = drive_clock.realtime()
    if not sched.startswith("SCHED_FIFO"):
        print("mock arm: " + sched + ": it may answer late on a busy machine", file=sys.stderr, flush=True)
    # The record and the bus log's pending frames hold no cycles; a full collection of a heap
    # that grows with the run (tens of ms after a minute) would answer late.
    gc.disable()
    # The drives answer from the main thread; the library's heartbeat threads must not keep it
    # waiting for the interpreter lock for the default 5 ms.
    sys.setswitchinterval(0.0002)
    folder = tempfile.mkdtemp(prefix="omcbsa-mock-arm-")
    path = os.path.join(folder, "slcan.sock")
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(path)
    listener.listen(1)
    # `--max-seconds=inf` (a cell's mock): wait for the host as long as it takes.
    listener.settimeout(args.max_seconds if math.isfinite(args.max_seconds) else None)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    print("SOCKET " + path, flush=True)
    try:
        conn, _ = listener.accept()
    except socket.timeout:
        return 1
    finally:
        listener.close()
        os.unlink(path)
        os.rmdir(folder)
    log = BusLog(args.bus_log) if args.bus_log else None
    bus = SlcanAdapterBus(conn.fileno(), log)
    arm = MockArm(args, bus)
    try:
        arm.run()
    except EOFError:
        pass
    finally:
        # The run is over: what is left must not keep a core from mocks still stopping.
        drive_clock.background()
        arm.write_record()
        bus.shutdown()
        if log is not None:
            log.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
