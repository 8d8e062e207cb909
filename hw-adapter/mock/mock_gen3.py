#!/usr/bin/env python3
"""Mock Kinova Gen3 on Kortex (API 2.6) over TCP and UDP, for tests of omcbsa's Kortex transport.

Independent of the Rust encoder: the messages come from the `protobuf` package, with Python code
that hw-adapter/mock/setup_venv.sh generates (grpcio-tools' protoc) from hw-adapter/proto into
<venv>/kortex-proto. The framing (TCP magic and length, the header's bit fields) is written out
here from Kinova's wire format.

Listens on 127.0.0.1 on a free TCP and a free UDP port (or --tcp-port / --udp-port) and prints
`PORTS <tcp> <udp>` as its first line. Serves one client: a session per link (CreateSession with
--user / --password), KeepAlive, CloseSession, ClearFaults, SetServoingMode, ApplyEmergencyStop,
RefreshFeedback and Refresh. Seven actuators follow their last position command with a
first-order lag in time (time constant --tau-ms): they keep moving between commands, and a
feedback reports where they are when it is sent; an arm in fault, in emergency stop, out of
low-level servoing or stopped for inactivity holds where it is.

Refuses what a real arm refuses, with an error frame, and for a cyclic command with an actuator
fault (fault bank A bit 0 of the actuator concerned, in every later Feedback, until ClearFaults):
a request on a link without a session; Refresh outside low-level servoing; a command past a
joint limit or faster than the velocity limit over --period-ms; a frame_id that is not the last
one plus one (a stale frame). Refresh after ApplyEmergencyStop is refused, and the arm holds.
When a link has been silent for the session's connection_inactivity_timeout, the arm stops
motion (it holds and refuses further cyclic commands).

Fault injection, counted in Refresh commands received in low-level servoing (1 is the first):
--silent-at N (no answer to anything from the Nth on), --late-at N with --late-ms D (every answer
from the Nth on sent D ms late), --fault-at N (actuator 3 reports a fault in the Nth answer on),
--drop-session-at N (both sessions forgotten: the Nth Refresh and every later request answered
with INVALID_SESSION). A slow network path: --udp-delay-ms D handles every UDP request after a
delay drawn from [0, D] ms (--seed), in arrival order, so that a TCP request sent after it can
be handled first.

Every request and event is recorded and written, as JSON lines, to --record at exit, with
time.monotonic() stamps (one clock for every process on the machine). The mock exits when its
client closes the TCP connection, on SIGTERM, or after --max-seconds.
"""

import argparse
import collections
import gc
import heapq
import json
import math
import os
import random
import select
import signal
import socket
import struct
import sys
import time

sys.path.insert(0, os.path.join(sys.prefix, "kortex-proto"))
import Base_pb2  # noqa: E402
import BaseCyclic_pb2  # noqa: E402
import Common_pb2  # noqa: E402,F401  (imported by the others)
import Frame_pb2  # noqa: E402
import Session_pb2  # noqa: E402

import drive_clock  # noqa: E402

MAGIC = bytes([0x07, 0x78, 0x45, 0x74, 0x52, 0x6F, 0x4B, 0x07])
REQUEST, RESPONSE = 1, 3
CREATE_SESSION, CLOSE_SESSION, KEEP_ALIVE = 0x10001, 0x10002, 0x10003
APPLY_EMERGENCY_STOP, CLEAR_FAULTS, SET_SERVOING_MODE = 0x20091, 0x20092, 0x20098
REFRESH, REFRESH_FEEDBACK = 0x30001, 0x30003
# Kinova.Api.ErrorCodes / SubErrorCodes (Errors.proto).
ERROR_PROTOCOL_SERVER, ERROR_DEVICE = 1, 3
METHOD_FAILED, INVALID_PARAM, INVALID_SESSION = 1, 3, 12
INVALID_PASSWORD, USER_NOT_FOUND = 15, 16
ROBOT_IN_FAULT, ROBOT_IN_EMERGENCY_STOP = 22, 25
SINGLE_LEVEL, LOW_LEVEL = 2, 3
JOINTS = 7
# Kinova Gen3: URDF position limits in degrees (None = continuous), velocity limit, as the
# CAN mock (mock_arm.py) uses them.
POSITION_LIMITS_DEG = [None, math.degrees(2.24), None, math.degrees(2.57), None,
                       math.degrees(2.09), None]
VELOCITY_LIMIT_DEG_S = math.degrees(0.8727)
# f32 degrees on the wire: about 3e-5 degrees of rounding per position.
SLACK_DEG = 1e-4
FAULTY_ACTUATOR = 3


def wrap180(deg):
    """deg in (-180, 180]."""
    d = math.fmod(deg, 360.0)
    if d > 180.0:
        d -= 360.0
    elif d <= -180.0:
        d += 360.0
    return d


def header_fields(h):
    return {
        "frame_type": (h.frame_info >> 24) & 0xF,
        "session": h.message_info >> 16,
        "message_id": h.message_info & 0xFFFF,
        "uid": h.service_info & 0x0FFFFFFF,
    }


def frame_bytes(request_header, payload=b"", error=None):
    """A response to the request whose header is given; `error` = (code, sub_code, text)."""
    f = Frame_pb2.Frame()
    h = f.header
    code, sub, body = 0, 0, payload
    if error is not None:
        code, sub, text = error
        e = Frame_pb2.Error(error_code=code, error_sub_code=sub, error_sub_string=text)
        body = e.SerializeToString()
    h.frame_info = (1 << 28) | (RESPONSE << 24) | ((code & 0xF) << 12) | (sub & 0xFFF)
    h.message_info = request_header.message_info
    h.service_info = request_header.service_info
    h.payload_info = len(body) & 0xFFFFFF
    f.payload = body
    return f.SerializeToString()


class Gen3:
    def __init__(self, args):
        self.args = args
        self.period = args.period_ms / 1000.0
        self.tau = args.tau_ms / 1000.0
        self.position = [math.degrees(q) % 360.0 for q in args.initial]
        self.command = list(self.position)  # the last position command taken
        self.goal = list(self.position)  # where the actuators head
        self.moved_at = time.monotonic()
        self.faults = [0] * JOINTS
        self.mode = SINGLE_LEVEL
        self.estopped = False
        self.motion_stopped = None  # why the arm stopped motion by itself
        self.sessions = {"tcp": 0, "udp": 0}
        self.inactivity = {"tcp": None, "udp": None}  # seconds, from CreateSession
        self.last_rx = {"tcp": time.monotonic(), "udp": time.monotonic()}
        self.next_session = 1
        self.last_frame_id = None
        self.refreshes = 0
        self.silent = False
        self.late = False
        self.dropped = False
        self.records = []
        self.pending = []  # (due, seq, link, peer, bytes): late answers
        self.seq = 0

    def record(self, event, **kw):
        kw["t"] = time.monotonic()
        kw["event"] = event
        self.records.append(kw)

    # Each handler returns (payload bytes) or raises Refusal.
    def handle(self, link, header, payload):
        """The response to one request frame on `link`, or None for no answer."""
        f = header_fields(header)
        uid = f["uid"]
        now = time.monotonic()
        self.last_rx[link] = now
        if f["frame_type"] != REQUEST:
            self.record("ignored", link=link, frame_type=f["frame_type"])
            return None
        if uid == REFRESH and self.mode == LOW_LEVEL and not self.dropped:
            self.refreshes += 1
            n = self.refreshes
            a = self.args
            if a.silent_at and n >= a.silent_at and not self.silent:
                self.silent = True
                self.record("silent_from", refresh=n)
            if a.late_at and n >= a.late_at and not self.late:
                self.late = True
                self.record("late_from", refresh=n, late_ms=a.late_ms)
            if a.fault_at and n == a.fault_at:
                self.faults[FAULTY_ACTUATOR - 1] |= 1
                self.record("fault_injected", refresh=n, actuator=FAULTY_ACTUATOR)
            if a.drop_session_at and n == a.drop_session_at:
                self.dropped = True
                self.sessions = {"tcp": 0, "udp": 0}
                self.record("session_dropped", refresh=n)
        if self.silent:
            if uid == REFRESH:
                self.record_refresh(payload, answer="silent")
            else:
                self.record("unanswered", link=link, uid=uid)
            return None
        try:
            if uid == CREATE_SESSION:
                body = self.create_session(link, payload, header)
            elif f["session"] == 0 or f["session"] != self.sessions[link]:
                if uid == REFRESH:
                    self.record_refresh(payload, answer="refused", why="no session")
                raise Refusal(ERROR_PROTOCOL_SERVER, INVALID_SESSION,
                              "no session %d on %s" % (f["session"], link))
            elif uid == KEEP_ALIVE:
                self.record("keepalive", link=link)
                body = b""
            elif uid == CLOSE_SESSION:
                self.sessions[link] = 0
                self.record("close_session", link=link)
                body = b""
            elif uid == CLEAR_FAULTS:
                self.faults = [0] * JOINTS
                self.estopped = False
                self.motion_stopped = None
                self.record("clear_faults")
                body = b""
            elif uid == APPLY_EMERGENCY_STOP:
                self.estopped = True
                self.hold()
                self.record("estop", link=link, uid=uid)
                body = b""
            elif uid == SET_SERVOING_MODE:
                info = Base_pb2.ServoingModeInformation.FromString(payload)
                self.mode = info.servoing_mode
                if self.mode != LOW_LEVEL:
                    self.hold()
                self.last_frame_id = None
                self.record("servoing", mode=self.mode)
                body = b""
            elif uid == REFRESH_FEEDBACK:
                body = self.feedback(0).SerializeToString()
            elif uid == REFRESH:
                body = self.refresh(payload)
            else:
                raise Refusal(ERROR_PROTOCOL_SERVER, 5, "unsupported method %#x" % uid)
        except Refusal as r:
            self.record("refused", link=link, uid=uid, why=r.text)
            return frame_bytes(header, error=(r.code, r.sub, r.text))
        return frame_bytes(header, body)

    def create_session(self, link, payload, header):
        info = Session_pb2.CreateSessionInfo.FromString(payload)
        if info.username != self.args.user:
            raise Refusal(ERROR_PROTOCOL_SERVER, USER_NOT_FOUND, "user not found")
        if info.password != self.args.password:
            raise Refusal(ERROR_PROTOCOL_SERVER, INVALID_PASSWORD, "wrong password")
        self.sessions[link] = self.next_session
        self.next_session += 1
        self.inactivity[link] = info.connection_inactivity_timeout / 1000.0 or None
        # The session id goes back in the response header's message_info.
        header.message_info = (self.sessions[link] << 16) | (header.message_info & 0xFFFF)
        self.record("session", link=link, session=self.sessions[link], user=info.username,
                    connection_inactivity_ms=info.connection_inactivity_timeout,
                    session_inactivity_ms=info.session_inactivity_timeout)
        return b""

    def advance(self):
        """Moves every actuator toward its goal for the time passed since the last call."""
        now = time.monotonic()
        k = 1.0 - math.exp(-(now - self.moved_at) / self.tau) if self.tau > 0 else 1.0
        self.moved_at = now
        for j in range(JOINTS):
            self.position[j] += k * wrap180(self.goal[j] - self.position[j])

    def hold(self):
        """The actuators stop where they are."""
        self.advance()
        self.goal = list(self.position)

    def feedback(self, frame_id):
        self.advance()
        fb = BaseCyclic_pb2.Feedback(frame_id=frame_id)
        for j in range(JOINTS):
            a = fb.actuators.add()
            a.command_id = frame_id
            a.position = self.position[j] % 360.0
            a.fault_bank_a = self.faults[j]
        return fb

    def record_refresh(self, payload, answer, why=None):
        try:
            c = BaseCyclic_pb2.Command.FromString(payload)
            frame_id, pos = c.frame_id, [a.position for a in c.actuators]
        except Exception:  # a payload that does not decode is recorded as such
            frame_id, pos = None, None
        self.record("refresh", frame_id=frame_id, positions=pos, answer=answer, why=why,
                    refresh=self.refreshes)

    def refresh(self, payload):
        c = BaseCyclic_pb2.Command.FromString(payload)
        pos = [a.position for a in c.actuators]

        def refuse(code, sub, why, actuators=()):
            for j in actuators:
                self.faults[j] |= 1
            if any(self.faults):
                self.hold()
            self.record_refresh(payload, answer="refused", why=why)
            raise Refusal(code, sub, why)

        if self.mode != LOW_LEVEL:
            refuse(ERROR_DEVICE, METHOD_FAILED, "cyclic command outside low-level servoing",
                   range(JOINTS))
        if self.estopped:
            refuse(ERROR_DEVICE, ROBOT_IN_EMERGENCY_STOP, "emergency stop applied")
        if self.motion_stopped:
            refuse(ERROR_DEVICE, ROBOT_IN_FAULT, self.motion_stopped)
        if len(pos) != JOINTS:
            refuse(ERROR_DEVICE, INVALID_PARAM, "%d actuator commands, not %d" % (len(pos), JOINTS))
        if self.last_frame_id is not None and c.frame_id != (self.last_frame_id + 1) & 0xFFFF:
            refuse(ERROR_DEVICE, INVALID_PARAM, "stale frame_id %d after %d"
                   % (c.frame_id, self.last_frame_id), range(JOINTS))
        for j, a in enumerate(c.actuators):
            if a.command_id != c.frame_id:
                refuse(ERROR_DEVICE, INVALID_PARAM, "actuator %d command_id %d in frame %d"
                       % (j + 1, a.command_id, c.frame_id), [j])
            if not 0.0 <= a.position < 360.0:
                refuse(ERROR_DEVICE, INVALID_PARAM, "actuator %d position %r outside [0, 360)"
                       % (j + 1, a.position), [j])
            lim = POSITION_LIMITS_DEG[j]
            if lim is not None and abs(wrap180(a.position)) > lim + SLACK_DEG:
                refuse(ERROR_DEVICE, INVALID_PARAM, "actuator %d position %.4f past its limit"
                       % (j + 1, a.position), [j])
            # The seed (first command) is where the arm is; later ones step from the last.
            if self.last_frame_id is not None:
                speed = abs(wrap180(a.position - self.command[j])) / self.period
                if speed > VELOCITY_LIMIT_DEG_S * (1 + 1e-3) + SLACK_DEG / self.period:
                    refuse(ERROR_DEVICE, INVALID_PARAM, "actuator %d too fast: %.3f deg/s"
                           % (j + 1, speed), [j])
        if any(self.faults):
            # In fault the arm holds; the answer still reports where it is and its faults.
            self.hold()
            self.record_refresh(payload, answer="fault")
        else:
            self.last_frame_id = c.frame_id
            self.advance()
            for j in range(JOINTS):
                self.command[j] = pos[j]
                self.goal[j] = pos[j]
            self.record_refresh(payload, answer="late" if self.late else "ok")
        return self.feedback(c.frame_id).SerializeToString()

    def check_inactivity(self, now):
        if self.mode != LOW_LEVEL or self.motion_stopped or self.estopped:
            return
        for link in ("tcp", "udp"):
            limit = self.inactivity[link]
            if self.sessions[link] and limit and now - self.last_rx[link] > limit:
                self.motion_stopped = "no frame on %s for %.3f s" % (link, now - self.last_rx[link])
                self.hold()
                self.record("inactivity_stop", link=link)

    def write_record(self):
        if self.args.record:
            with open(self.args.record, "w") as out:
                for r in self.records:
                    out.write(json.dumps(r) + "\n")


class Refusal(Exception):
    def __init__(self, code, sub, text):
        super().__init__(text)
        self.code, self.sub, self.text = code, sub, text


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--initial", required=True,
                   help="joint positions at power-on, rad, comma separated")
    p.add_argument("--tcp-port", type=int, default=0)
    p.add_argument("--udp-port", type=int, default=0)
    p.add_argument("--user", default="admin")
    p.add_argument("--password", default="admin")
    p.add_argument("--period-ms", type=float, default=1.0,
                   help="the client's control period, for the velocity check of each command")
    p.add_argument("--tau-ms", type=float, default=5.0,
                   help="time constant of the actuators' first-order lag behind their command")
    p.add_argument("--record")
    p.add_argument("--max-seconds", type=float, default=600.0)
    p.add_argument("--silent-at", type=int, default=0)
    p.add_argument("--late-at", type=int, default=0)
    p.add_argument("--late-ms", type=float, default=0.0)
    p.add_argument("--fault-at", type=int, default=0)
    p.add_argument("--drop-session-at", type=int, default=0)
    p.add_argument("--udp-delay-ms", type=float, default=0.0,
                   help="handle each UDP request after a delay drawn from [0, D] ms, in order")
    p.add_argument("--seed", type=int, default=0, help="of the UDP delays")
    args = p.parse_args()
    args.initial = [float(x) for x in args.initial.split(",")]
    if len(args.initial) != JOINTS:
        p.error("--initial needs %d positions, got %d" % (JOINTS, len(args.initial)))

    # The record holds no cycles; a collection pause of the growing record would answer late.
    gc.disable()
    # A Gen3's actuators have processors of their own: the mock must not wait behind the host.
    sched = drive_clock.realtime()
    if not sched.startswith("SCHED_FIFO"):
        print("mock arm: " + sched + ": it may answer late on a busy machine", file=sys.stderr, flush=True)
    arm = Gen3(args)
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", args.tcp_port))
    listener.listen(1)
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind(("127.0.0.1", args.udp_port))
    udp.setblocking(False)
    print("PORTS %d %d" % (listener.getsockname()[1], udp.getsockname()[1]), flush=True)

    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append("SIGTERM"))
    conn, rx = None, b""
    had_client = False
    deadline = time.monotonic() + args.max_seconds

    def answer(link, peer, data):
        if data is None:
            return
        if arm.late and link == "udp":
            arm.seq += 1
            heapq.heappush(arm.pending, (time.monotonic() + args.late_ms / 1000.0, arm.seq,
                                         link, peer, data))
            return
        send(link, peer, data)

    def send(link, peer, data):
        if link == "udp":
            udp.sendto(data, peer)
        elif conn is not None:
            conn.sendall(MAGIC + struct.pack(">I", len(data)) + data)

    rng = random.Random(args.seed)
    udp_in = collections.deque()  # (due, bytes, peer): UDP requests on a slow path

    def handle_udp(data, peer):
        f = Frame_pb2.Frame.FromString(data)
        answer("udp", peer, arm.handle("udp", f.header, f.payload))

    def handle_due_udp(until):
        while udp_in and udp_in[0][0] <= until:
            _, data, peer = udp_in.popleft()
            handle_udp(data, peer)

    try:
        while not stop and time.monotonic() < deadline:
            now = time.monotonic()
            handle_due_udp(now)
            while arm.pending and arm.pending[0][0] <= now:
                _, _, link, peer, data = heapq.heappop(arm.pending)
                send(link, peer, data)
            arm.check_inactivity(now)
            timeout = 0.05
            if arm.pending:
                timeout = max(0.0, min(timeout, arm.pending[0][0] - now))
            if udp_in:
                timeout = max(0.0, min(timeout, udp_in[0][0] - now))
            socks = [listener, udp] + ([conn] if conn is not None else [])
            try:
                ready, _, _ = select.select(socks, [], [], timeout)
            except InterruptedError:
                continue
            if listener in ready:
                c, _ = listener.accept()
                if conn is None:
                    conn, rx, had_client = c, b"", True
                    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                else:
                    c.close()  # one client at a time
            if udp in ready:
                while True:
                    try:
                        data, peer = udp.recvfrom(65536)
                    except BlockingIOError:
                        break
                    if args.udp_delay_ms > 0:
                        due = time.monotonic() + rng.uniform(0.0, args.udp_delay_ms) / 1000.0
                        udp_in.append((max(due, udp_in[-1][0]) if udp_in else due, data, peer))
                    else:
                        handle_udp(data, peer)
            if conn is not None and conn in ready:
                chunk = conn.recv(65536)
                if not chunk:
                    arm.record("tcp_closed")
                    conn.close()
                    conn = None
                    if had_client:
                        # Requests still on the slow path arrive all the same.
                        if udp_in:
                            time.sleep(max(0.0, udp_in[-1][0] - time.monotonic()))
                            handle_due_udp(udp_in[-1][0])
                        break
                    continue
                rx += chunk
                while len(rx) >= 12:
                    if rx[:8] != MAGIC:
                        arm.record("bad_magic", bytes=rx[:8].hex())
                        rx = b""
                        break
                    (n,) = struct.unpack(">I", rx[8:12])
                    if len(rx) < 12 + n:
                        break
                    f = Frame_pb2.Frame.FromString(rx[12:12 + n])
                    rx = rx[12 + n:]
                    answer("tcp", None, arm.handle("tcp", f.header, f.payload))
    finally:
        # The run is over: what is left must not keep a core from mocks still stopping.
        drive_clock.background()
        arm.write_record()


if __name__ == "__main__":
    main()
