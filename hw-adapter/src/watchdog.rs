//! Per-cycle accounting of a cyclic exchange, independent of the transport: the host sends
//! cycle 0, 1, 2, ... (a CANopen SYNC after its RPDOs; a UDP command) and every source (a drive
//! node, an actuator) answers every cycle. Each answer is matched to the cycle it answers:
//! in order ([`CycleAccount::answer_next`], CANopen: a TPDO1 on every SYNC carries no cycle
//! number) or by the cycle it names ([`CycleAccount::answer`]). With `m` =
//! [`CycleAccount::missed`] (default [`DEFAULT_MISSED_CYCLES`]):
//!
//! - a source whose answer to cycle k has not arrived when cycle k + m is to be sent is a fault
//!   ([`CycleFault::Missing`], from [`CycleAccount::check_send`]);
//! - an answer to cycle k that arrives once cycle k + m has been sent is more than m periods
//!   stale: "late", a fault ([`CycleFault::Late`]).
//!
//! Counting cycles rather than wall-clock time makes the bound m periods at any period, and
//! tells a silent source from a host that is itself late (no cycle sent, nothing owed).
//! Memory is bounded: the records of the last m + 1 cycles sent and one counter per source.
//!
//! ```
//! use omcbsa_hw::watchdog::{CycleAccount, CycleFault};
//!
//! // Two drives, m = 2; each cycle's record is its number.
//! let mut account = CycleAccount::new(2, 2)?;
//! account.sent_cycle(0);
//! account.answer_next(0).unwrap(); // drive 0 answers cycle 0; drive 1 stays silent
//! account.check_send().unwrap();
//! account.sent_cycle(1); // cycle 1 = 0 + m - 1: still allowed
//! assert_eq!(account.clear_until(), 2);
//! // Cycle 2 = 0 + m is due and drive 1 still owes cycle 0: a fault, before cycle 2 is sent.
//! let fault = account.check_send().unwrap_err();
//! assert_eq!(fault, CycleFault::Missing { source: 1, cycle: 0, next: 2 });
//! // An answer that comes after cycle k + m was sent is late.
//! account.sent_cycle(2);
//! assert!(matches!(account.answer_next(1), Err(CycleFault::Late { cycle: 0, .. })));
//! # Ok::<(), String>(())
//! ```

use std::collections::VecDeque;

use crate::run::WatchSettings;
pub use crate::run::{CycleFault, DEFAULT_MISSED_CYCLES, MAX_MISSED_CYCLES};

/// The accounting of one link (one bus, one UDP peer) with its sources; `T` is what the caller
/// keeps about each cycle sent (e.g. when, and the targets sent), handed back with the answer
/// that matches it.
#[derive(Clone, Debug)]
pub struct CycleAccount<T> {
    missed: u64,
    /// Cycles sent so far: the next one is cycle `sent`.
    sent: u64,
    /// Records of cycles `sent - records.len()` to `sent - 1` (at most m + 1).
    records: VecDeque<T>,
    /// Per source, the first cycle it has not answered.
    owed: Vec<u64>,
}

impl<T> CycleAccount<T> {
    /// An account of `sources` sources, a fault after `missed` (1 to [`MAX_MISSED_CYCLES`])
    /// periods without an answer.
    pub fn new(sources: usize, missed: u32) -> Result<Self, String> {
        if !(1..=MAX_MISSED_CYCLES).contains(&missed) {
            return Err(format!(
                "missed cycles must be within [1, {MAX_MISSED_CYCLES}], got {missed}"
            ));
        }
        Ok(Self::with_missed(sources, missed))
    }

    /// The account of a link with `sources` sources under `watch`'s `m`
    /// ([`WatchSettings::missed_cycles`], clamped into its range: a run refuses settings out
    /// of range before any link is set up).
    pub fn watching(sources: usize, watch: &WatchSettings) -> Self {
        Self::with_missed(sources, watch.missed_cycles.clamp(1, MAX_MISSED_CYCLES))
    }

    fn with_missed(sources: usize, missed: u32) -> Self {
        Self {
            missed: u64::from(missed),
            sent: 0,
            records: VecDeque::with_capacity(missed as usize + 1),
            owed: vec![0; sources],
        }
    }

    /// `m`: the periods an answer may lag its cycle.
    pub fn missed(&self) -> u32 {
        self.missed as u32
    }

    /// Cycles sent since the start (or the last [`CycleAccount::reset`]).
    pub fn sent(&self) -> u64 {
        self.sent
    }

    /// The first cycle `source` has not answered (`None` for an unknown source).
    pub fn owed(&self, source: usize) -> Option<u64> {
        self.owed.get(source).copied()
    }

    /// Forgets every cycle: from here on, each cycle sent is owed an answer by every source.
    pub fn reset(&mut self) {
        self.sent = 0;
        self.records.clear();
        self.owed.iter_mut().for_each(|o| *o = 0);
    }

    /// Whether the next cycle (number [`CycleAccount::sent`]) may be sent: every source must
    /// have answered every cycle before `next - m + 1`. Call it when the next cycle is due.
    pub fn check_send(&self) -> Result<(), CycleFault> {
        let next = self.sent;
        match (self.owed.iter().enumerate()).min_by_key(|(_, &o)| o) {
            Some((source, &cycle)) if cycle + self.missed <= next => Err(CycleFault::Missing {
                source,
                cycle,
                next,
            }),
            _ => Ok(()),
        }
    }

    /// The first cycle the answers so far do not allow to be sent (every cycle before it may
    /// be): for links that stream in lockstep, so that no link sends a cycle another link's
    /// account forbids.
    pub fn clear_until(&self) -> u64 {
        self.owed.iter().min().map_or(u64::MAX, |o| o + self.missed)
    }

    /// Records that the next cycle was sent, keeping `record` about it; returns its number.
    pub fn sent_cycle(&mut self, record: T) -> u64 {
        if self.records.len() as u64 > self.missed {
            self.records.pop_front();
        }
        self.records.push_back(record);
        self.sent += 1;
        self.sent - 1
    }

    /// The record of the last cycle sent.
    pub fn last_mut(&mut self) -> Option<&mut T> {
        self.records.back_mut()
    }

    /// The record of `cycle`, if it is one of the last m + 1 sent.
    pub fn record(&self, cycle: u64) -> Option<&T> {
        let first = self.sent - self.records.len() as u64;
        (cycle >= first)
            .then(|| self.records.get((cycle - first) as usize))
            .flatten()
    }

    /// An answer of `source` that answers the oldest cycle it owes (in-order links): returns
    /// the cycle and its record, or `None` if it owes none (an answer to nothing sent since
    /// the reset is no news: ignored) or is unknown.
    pub fn answer_next(&mut self, source: usize) -> Result<Option<(u64, &T)>, CycleFault> {
        let Some(&cycle) = self.owed.get(source) else {
            return Ok(None);
        };
        if cycle >= self.sent {
            return Ok(None);
        }
        self.answer(source, cycle)
    }

    /// An answer of `source` to `cycle` (links whose answers name their cycle): answers every
    /// cycle up to `cycle` (an answer is the source's state, so a newer one stands for older
    /// ones lost). An answer to a cycle already answered is no news (`None`); one to a cycle
    /// not sent is a fault.
    pub fn answer(&mut self, source: usize, cycle: u64) -> Result<Option<(u64, &T)>, CycleFault> {
        let sent = self.sent;
        let Some(owed) = self.owed.get_mut(source) else {
            return Ok(None);
        };
        if cycle >= sent {
            return Err(CycleFault::Unsent {
                source,
                cycle,
                sent,
            });
        }
        if cycle < *owed {
            return Ok(None);
        }
        *owed = cycle + 1;
        // Cycle k answered once k + m is out: more than m periods stale.
        if cycle + self.missed < sent {
            return Err(CycleFault::Late {
                source,
                cycle,
                last_sent: sent - 1,
            });
        }
        Ok(self.record(cycle).map(|r| (cycle, r)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two sources, m = 2; records are the cycle numbers.
    fn account() -> CycleAccount<u64> {
        CycleAccount::new(2, 2).unwrap()
    }

    fn send(a: &mut CycleAccount<u64>) -> u64 {
        let k = a.sent();
        a.sent_cycle(k)
    }

    #[test]
    fn answers_in_time_keep_it_clear() {
        let mut a = account();
        for k in 0..100 {
            a.check_send().unwrap();
            assert_eq!(send(&mut a), k);
            // each source answers the cycle before last: one period behind, within m = 2
            if k >= 1 {
                for s in 0..2 {
                    assert_eq!(a.answer_next(s).unwrap(), Some((k - 1, &(k - 1))));
                }
            }
        }
        assert_eq!(a.clear_until(), 99 + 2);
    }

    #[test]
    fn missing_answer_is_a_fault_when_cycle_k_plus_m_is_due() {
        let mut a = account();
        send(&mut a); // cycle 0
        a.answer_next(0).unwrap();
        a.answer_next(1).unwrap();
        send(&mut a); // cycle 1: source 1 never answers it
        a.answer_next(0).unwrap();
        a.check_send().unwrap();
        send(&mut a); // cycle 2 (1 + m - 1): still allowed
        a.answer_next(0).unwrap();
        assert_eq!(a.clear_until(), 3);
        // cycle 3 = 1 + m is due: source 1 still owes cycle 1
        assert_eq!(
            a.check_send(),
            Err(CycleFault::Missing {
                source: 1,
                cycle: 1,
                next: 3
            })
        );
        let text = a.check_send().unwrap_err().to_string();
        assert!(
            text.contains("cycle 1") && text.contains("2 periods"),
            "{text}"
        );
    }

    #[test]
    fn an_answer_more_than_m_periods_stale_is_late() {
        let mut a: CycleAccount<u64> = CycleAccount::new(1, 2).unwrap();
        for _ in 0..3 {
            send(&mut a); // cycles 0, 1, 2 (the sender did not check: it is the answer's turn)
        }
        // the answer to cycle 0 after cycle 2 = 0 + m was sent
        assert_eq!(
            a.answer_next(0),
            Err(CycleFault::Late {
                source: 0,
                cycle: 0,
                last_sent: 2
            })
        );
        // the answer to cycle 1 is exactly m - 1 = 1 period behind cycle 2: in time
        assert_eq!(a.answer_next(0), Ok(Some((1, &1))));
    }

    #[test]
    fn answers_naming_their_cycle() {
        let mut a: CycleAccount<u64> = CycleAccount::new(1, 2).unwrap();
        for _ in 0..4 {
            send(&mut a);
        }
        // cycles 0-2 lost, 3 answered: the newest state covers them
        assert_eq!(a.answer(0, 3), Ok(Some((3, &3))));
        assert_eq!(a.owed(0), Some(4));
        // an old duplicate is no news
        assert_eq!(a.answer(0, 1), Ok(None));
        // an answer to a cycle not sent
        assert_eq!(
            a.answer(0, 9),
            Err(CycleFault::Unsent {
                source: 0,
                cycle: 9,
                sent: 4
            })
        );
        // in order after that, with nothing owed: no news
        assert_eq!(a.answer_next(0), Ok(None));
    }

    #[test]
    fn memory_is_bounded_to_m_plus_one_records() {
        let mut a: CycleAccount<u64> = CycleAccount::new(1, 3).unwrap();
        for _ in 0..1000 {
            send(&mut a);
            a.answer_next(0).unwrap();
        }
        assert_eq!(a.records.len(), 4);
        assert_eq!(a.record(999), Some(&999));
        assert_eq!(a.record(996), Some(&996));
        assert_eq!(a.record(995), None);
    }

    #[test]
    fn reset_forgets_what_was_owed() {
        let mut a = account();
        for _ in 0..5 {
            send(&mut a);
        }
        assert!(a.check_send().is_err());
        a.reset();
        assert_eq!(a.check_send(), Ok(()));
        assert_eq!(a.answer_next(0), Ok(None));
        assert_eq!(send(&mut a), 0);
    }

    #[test]
    fn settings_out_of_range_are_refused() {
        assert!(CycleAccount::<()>::new(1, 0).unwrap_err().contains("got 0"));
        assert!(CycleAccount::<()>::new(1, MAX_MISSED_CYCLES + 1).is_err());
        let a = CycleAccount::<()>::new(0, 1).unwrap();
        assert_eq!(a.check_send(), Ok(()));
        assert_eq!(a.clear_until(), u64::MAX);
    }
}
