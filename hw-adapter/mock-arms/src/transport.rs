//! In-process CAN bus with a bitrate: two connected ends, one for the host, one for a simulated
//! device, sharing one wire.
//!
//! The wire is modelled arithmetically, without a thread of its own: a frame sent takes the
//! bus when the bus is idle and this end's earlier frames are gone, for its bits
//! ([`omcbsa_hw::bus::frame_bits`]) at the bitrate, and the other end receives it no earlier than
//! when its last bit (and the interframe space) has passed. When the bus goes idle with frames
//! waiting at both ends, the lower identifier wins (CAN's arbitration); each end sends its own
//! frames in order (one transmit queue, as a SocketCAN interface's). The schedule is worked
//! out when an end looks at the bus (sends or receives), from the instants the frames were
//! queued at, so a receiver woken late (a thread's wakeup costs 50-200 µs on a small machine)
//! gets every frame whose instant has passed, at once, and the bus's timing does not drift
//! with the machine's. Costs, per frame: its bits counted ([`omcbsa_hw::bus::frame_bits`]) when it
//! takes the wire and while a receiver waits for it, under the bus's one lock.

use omcbsa_hw::bus::{frame_bits, wire_time, DEFAULT_BITRATE};
use omcbsa_hw::frame::CanFrame;
use omcbsa_hw::transport::{ArmBuses, Transport, TransportError};
use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// How the in-process bus carries frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wire {
    /// Bits per second ([`DEFAULT_BITRATE`], 1 Mbit/s, by default).
    pub bitrate: u32,
    /// The most frames one direction holds, waiting for the bus, on it, or received and not
    /// yet read (256 by default: 16 cycles of a CiA 402 arm). A send that finds no room waits
    /// for it at most its time-out, then fails with [`TransportError::SendTimeout`]; memory is
    /// bounded by it.
    pub queue: usize,
}

impl Default for Wire {
    fn default() -> Self {
        Self {
            bitrate: DEFAULT_BITRATE,
            queue: 256,
        }
    }
}

/// A frame and an instant: when it was queued (waiting) or when it has arrived (arriving).
type Timed = (Instant, CanFrame);

/// The bus both ends share.
struct Bus {
    wire: Wire,
    /// When the frame on the wire (if any) has passed.
    busy_until: Instant,
    /// Per sending end: frames queued, not yet on the wire, in order.
    waiting: [VecDeque<Timed>; 2],
    /// Per receiving end: frames on or past the wire, with the instant each has arrived.
    arriving: [VecDeque<Timed>; 2],
    /// Per end: not dropped.
    open: [bool; 2],
}

impl Bus {
    /// Puts on the wire every frame whose turn has come by `now`: when the bus goes idle, the
    /// lower identifier among the ends' first waiting frames queued by then.
    fn advance(&mut self, now: Instant) {
        loop {
            let heads = [0, 1].map(|e| self.waiting[e].front().copied());
            let Some(ready) = heads.iter().flatten().map(|h| h.0).min() else {
                return;
            };
            let start = self.busy_until.max(ready);
            if start > now {
                return;
            }
            let Some(winner) = (0..2)
                .filter(|&e| heads[e].is_some_and(|h| h.0 <= start))
                .min_by_key(|&e| heads[e].map(|h| h.1.id()))
            else {
                return;
            };
            if let Some((_, frame)) = self.waiting[winner].pop_front() {
                self.busy_until = start + self.wire_time(&frame);
                self.arriving[1 - winner].push_back((self.busy_until, frame));
            }
        }
    }

    fn wire_time(&self, frame: &CanFrame) -> Duration {
        wire_time(frame_bits(frame), self.wire.bitrate)
    }

    /// Frames from `end` not yet read by the other end.
    fn unread(&self, end: usize) -> usize {
        self.waiting[end].len() + self.arriving[1 - end].len()
    }

    /// When something may next arrive at `end`: its first arriving frame; else, with frames
    /// waiting, the next arbitration or, when only the other end waits (this end, receiving,
    /// sends nothing meanwhile), the arrival of the other end's first frame.
    fn next_event(&self, end: usize) -> Option<Instant> {
        if let Some(&(at, _)) = self.arriving[end].front() {
            return Some(at);
        }
        let heads = [0, 1].map(|e| self.waiting[e].front().copied());
        match heads {
            [None, None] => None,
            _ if heads[end].is_none() => {
                heads[1 - end].map(|(ready, f)| self.busy_until.max(ready) + self.wire_time(&f))
            }
            _ => heads
                .iter()
                .flatten()
                .map(|h| self.busy_until.max(h.0))
                .min(),
        }
    }
}

struct Shared {
    bus: Mutex<Bus>,
    /// Notified whenever a frame is queued, read, or an end is dropped.
    changed: Condvar,
}

/// One end of an in-process CAN bus; what one end sends, the other receives, after the frame's
/// time on the wire (see the module). Once one end is dropped, the other receives what was
/// already sent, then its sends and receives are [`TransportError::Closed`].
///
/// ```
/// use omcbsa_mock::transport::MockTransport;
/// use omcbsa_hw::{CanFrame, Transport, TransportError};
/// use std::time::{Duration, Instant};
///
/// let (mut host, mut drive) = MockTransport::pair("left"); // 1 Mbit/s
/// let sync = CanFrame::new(0x080, &[]).unwrap();
/// let sent = Instant::now();
/// host.send(&sync, Duration::ZERO)?;
/// assert_eq!(drive.recv(Duration::from_millis(10))?, Some(sync));
/// assert!(sent.elapsed() >= Duration::from_micros(47)); // its 47 bits (and interframe space)
/// assert_eq!(drive.recv(Duration::ZERO)?, None); // nothing more: polls without waiting
/// drop(host);
/// assert!(matches!(drive.recv(Duration::ZERO), Err(TransportError::Closed { .. })));
/// # Ok::<(), TransportError>(())
/// ```
pub struct MockTransport {
    name: String,
    /// 0: the host's end, 1: the device's.
    end: usize,
    shared: Arc<Shared>,
}

impl MockTransport {
    /// Two connected ends named `mock:NAME` (host side first), on a bus of [`Wire::default`]
    /// (1 Mbit/s).
    pub fn pair(name: &str) -> (Self, Self) {
        Self::pair_with(name, Wire::default())
    }

    /// Two connected ends named `mock:NAME` (host side first), on a bus carrying frames as
    /// `wire` says.
    pub fn pair_with(name: &str, wire: Wire) -> (Self, Self) {
        let now = Instant::now();
        let shared = Arc::new(Shared {
            bus: Mutex::new(Bus {
                wire,
                busy_until: now,
                waiting: Default::default(),
                arriving: Default::default(),
                open: [true; 2],
            }),
            changed: Condvar::new(),
        });
        let name = format!("mock:{name}");
        let end = |end| Self {
            name: name.clone(),
            end,
            shared: shared.clone(),
        };
        (end(0), end(1))
    }

    /// One mock bus per arm: the host ends, named after the arms (for an executor), and the
    /// device ends, in the same order (for the test to read or answer).
    pub fn buses(arms: &[&str]) -> (ArmBuses, Vec<MockTransport>) {
        arms.iter()
            .map(|name| {
                let (host, device) = Self::pair(name);
                (
                    (name.to_string(), Box::new(host) as Box<dyn Transport>),
                    device,
                )
            })
            .unzip()
    }

    /// Every frame that has arrived by now, without waiting (frames still on the wire stay).
    pub fn drain(&mut self) -> Vec<CanFrame> {
        let mut bus = self.lock();
        let now = Instant::now();
        bus.advance(now);
        let arrived = bus.arriving[self.end]
            .iter()
            .take_while(|f| f.0 <= now)
            .count();
        let frames = bus.arriving[self.end]
            .drain(..arrived)
            .map(|f| f.1)
            .collect();
        self.shared.changed.notify_all();
        frames
    }

    /// Whether frames sent to this end have yet to arrive (waiting for the bus or on it).
    pub fn in_flight(&self) -> bool {
        let mut bus = self.lock();
        let now = Instant::now();
        bus.advance(now);
        // Frames arrive in the order they take the wire: the last one arrives last.
        !bus.waiting[1 - self.end].is_empty()
            || bus.arriving[self.end].back().is_some_and(|f| f.0 > now)
    }

    fn lock(&self) -> MutexGuard<'_, Bus> {
        // A thread that panicked holding the lock left the bus consistent: every change is
        // one push or pop.
        self.shared.bus.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits on the bus until `until` at the latest.
    fn wait<'a>(&self, bus: MutexGuard<'a, Bus>, until: Instant) -> MutexGuard<'a, Bus> {
        let left = until.saturating_duration_since(Instant::now());
        match self.shared.changed.wait_timeout(bus, left) {
            Ok((bus, _)) => bus,
            Err(e) => e.into_inner().0,
        }
    }

    fn closed(&self) -> TransportError {
        TransportError::Closed {
            bus: self.name.clone(),
        }
    }
}

impl Drop for MockTransport {
    fn drop(&mut self) {
        self.lock().open[self.end] = false;
        self.shared.changed.notify_all();
    }
}

impl Transport for MockTransport {
    fn name(&self) -> &str {
        &self.name
    }

    fn bitrate(&self) -> u32 {
        self.lock().wire.bitrate
    }

    fn send(&mut self, frame: &CanFrame, timeout: Duration) -> Result<(), TransportError> {
        let deadline = Instant::now() + timeout;
        let mut bus = self.lock();
        loop {
            let now = Instant::now();
            if !bus.open[1 - self.end] {
                return Err(self.closed());
            }
            bus.advance(now);
            if bus.unread(self.end) < bus.wire.queue {
                bus.waiting[self.end].push_back((now, *frame));
                bus.advance(now);
                self.shared.changed.notify_all();
                return Ok(());
            }
            if now >= deadline {
                return Err(TransportError::SendTimeout {
                    bus: self.name.clone(),
                    frame: *frame,
                    timeout,
                });
            }
            // Room comes when the other end reads (it notifies).
            bus = self.wait(bus, deadline);
        }
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, TransportError> {
        let deadline = Instant::now() + timeout;
        let mut bus = self.lock();
        loop {
            let now = Instant::now();
            bus.advance(now);
            let queue = &mut bus.arriving[self.end];
            if queue.front().is_some_and(|f| f.0 <= now) {
                let frame = queue.pop_front().map(|f| f.1);
                self.shared.changed.notify_all();
                return Ok(frame);
            }
            let next = bus.next_event(self.end);
            if next.is_none() && !bus.open[1 - self.end] {
                return Err(self.closed());
            }
            if now >= deadline {
                return Ok(None);
            }
            bus = self.wait(bus, next.map_or(deadline, |n| n.min(deadline)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use omcbsa_hw::bus::worst_case_bits;

    /// 10 kbit/s: a frame takes milliseconds, far above a thread's wakeup.
    const SLOW: Wire = Wire {
        bitrate: 10_000,
        queue: 256,
    };

    fn frame(id: u16, len: usize) -> CanFrame {
        CanFrame::new(id, &[0x55; 8][..len]).unwrap()
    }

    #[test]
    fn frames_cross_between_ends() {
        let (mut host, mut dev) = MockTransport::pair("a");
        let f = CanFrame::new(0x80, &[]).unwrap();
        host.send(&f, Duration::ZERO).unwrap();
        assert_eq!(dev.recv(Duration::from_millis(10)).unwrap(), Some(f));
        assert_eq!(dev.recv(Duration::ZERO).unwrap(), None);
        drop(host);
        assert!(matches!(
            dev.recv(Duration::ZERO),
            Err(TransportError::Closed { .. })
        ));
    }

    #[test]
    fn frames_arrive_no_earlier_than_their_time_on_the_wire() {
        // 10 kbit/s: an 8-byte frame takes at least 11.1 ms, ten of them back to back at
        // least 111 ms (whatever the machine: the receiver may only be later).
        let wire = SLOW;
        let (mut host, mut dev) = MockTransport::pair_with("slow", wire);
        let start = Instant::now();
        for i in 0..10 {
            host.send(&frame(0x200 + i, 8), Duration::ZERO).unwrap();
        }
        let mut bits = 0;
        for i in 0..10 {
            let f = dev.recv(Duration::from_secs(5)).unwrap().unwrap();
            assert_eq!(f.id(), 0x200 + i, "in the order sent");
            bits += frame_bits(&f);
            assert!(
                start.elapsed() >= wire_time(bits, wire.bitrate),
                "frame {i}"
            );
        }
        assert!(bits >= 10 * (64 + 47));
        assert!(bits <= 10 * worst_case_bits(8));
        // Nothing arrives early: a poll right after a send finds nothing, but the frame is on
        // its way.
        host.send(&frame(0x100, 8), Duration::ZERO).unwrap();
        assert_eq!(dev.recv(Duration::ZERO).unwrap(), None);
        assert!(dev.in_flight());
        assert!(dev.recv(Duration::from_secs(5)).unwrap().is_some());
        assert!(!dev.in_flight());
    }

    #[test]
    fn the_lower_id_wins_when_the_bus_goes_idle() {
        // 1 kbit/s: the first frame is on the wire for 111 ms, the time the test's thread has to
        // queue the other two (a loaded machine holds a thread up for tens of milliseconds).
        let wire = Wire {
            bitrate: 1_000,
            ..SLOW
        };
        let (mut host, mut dev) = MockTransport::pair_with("arb", wire);
        // The host's first frame takes the idle bus; while it is on the wire, the host queues
        // 0x300 and the device 0x180: at idle, 0x180 wins, then 0x300.
        host.send(&frame(0x400, 8), Duration::ZERO).unwrap();
        host.send(&frame(0x300, 8), Duration::ZERO).unwrap();
        dev.send(&frame(0x180, 8), Duration::ZERO).unwrap();
        assert_eq!(
            dev.recv(Duration::from_secs(5)).unwrap().map(|f| f.id()),
            Some(0x400)
        );
        let answer = host.recv(Duration::from_secs(5)).unwrap().map(|f| f.id());
        let answered = Instant::now();
        assert_eq!(answer, Some(0x180));
        assert_eq!(
            dev.recv(Duration::from_secs(5)).unwrap().map(|f| f.id()),
            Some(0x300)
        );
        // 0x300 came after 0x180 had left the wire: a whole frame's time at least.
        assert!(answered.elapsed() >= wire_time(64 + 47, wire.bitrate));
    }

    #[test]
    fn a_full_bus_refuses_a_frame_after_its_time_out() {
        let wire = Wire {
            bitrate: 1_000_000,
            queue: 4,
        };
        let (mut host, mut dev) = MockTransport::pair_with("full", wire);
        for i in 0..4 {
            host.send(&frame(0x200 + i, 6), Duration::ZERO).unwrap();
        }
        let e = host.send(&frame(0x204, 6), Duration::from_millis(1));
        assert!(
            matches!(e, Err(TransportError::SendTimeout { .. })),
            "{e:?}"
        );
        // Read one, and there is room for one more.
        assert!(dev.recv(Duration::from_secs(1)).unwrap().is_some());
        host.send(&frame(0x204, 6), Duration::ZERO).unwrap();
        let mut left = 0;
        while dev.recv(Duration::from_millis(100)).unwrap().is_some() {
            left += 1;
        }
        assert_eq!(left, 4);
    }
}
