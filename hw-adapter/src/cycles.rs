//! Per-cycle accounting of feedback: every command sent in a control cycle is owed one answer,
//! matched to it by its sequence number; an answer still missing `late_cycles` periods after
//! its command was sent (silence, or an answer that comes late) is a fault. Transport-neutral:
//! the Kortex arm keys it by frame_id.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// One command still owed an answer.
#[derive(Clone, Copy, Debug)]
struct Owed<T> {
    seq: u64,
    sent: Instant,
    what: T,
}

/// The commands sent and not yet answered, oldest first; `T` is what the caller needs back when
/// the answer comes (the targets of that cycle).
#[derive(Debug)]
pub struct CycleLedger<T> {
    owed: VecDeque<Owed<T>>,
    /// Commands sent so far; the next one's sequence number.
    sent: u64,
}

/// An answer owed for too long.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unanswered {
    /// Sequence number (control cycle) of the oldest unanswered command.
    pub seq: u64,
    /// Since it was sent.
    pub waited: Duration,
}

impl<T: Copy> Default for CycleLedger<T> {
    fn default() -> Self {
        Self {
            owed: VecDeque::new(),
            sent: 0,
        }
    }
}

impl<T: Copy> CycleLedger<T> {
    /// Records a command sent at `at`; returns its sequence number.
    pub fn sent(&mut self, at: Instant, what: T) -> u64 {
        let seq = self.sent;
        self.sent += 1;
        self.owed.push_back(Owed {
            seq,
            sent: at,
            what,
        });
        seq
    }

    /// Records the answer to command `seq`: what was sent with it, or `None` if it is owed no
    /// answer (answered already, or dropped as older than an answered one: answers come in
    /// order, so an older one still missing was lost).
    pub fn answered(&mut self, seq: u64) -> Option<T> {
        self.answered_where(|s, _| s == seq)
    }

    /// As [`CycleLedger::answered`], for the owed command that `is` picks by its sequence
    /// number and what was sent with it (e.g. the request's message id).
    pub fn answered_where(&mut self, is: impl Fn(u64, &T) -> bool) -> Option<T> {
        let i = self.owed.iter().position(|o| is(o.seq, &o.what))?;
        let o = self.owed.drain(..=i).last();
        o.map(|o| o.what)
    }

    /// The oldest command unanswered for `late_cycles` periods or more at `now`, if any.
    pub fn overdue(&self, now: Instant, period: Duration, late_cycles: u32) -> Option<Unanswered> {
        let o = self.owed.front()?;
        let waited = now.saturating_duration_since(o.sent);
        (waited >= period * late_cycles).then_some(Unanswered { seq: o.seq, waited })
    }

    /// Commands sent so far.
    pub fn count(&self) -> u64 {
        self.sent
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_answer_missing_for_late_cycles_periods_is_overdue_and_answers_match_their_command() {
        let p = Duration::from_millis(1);
        let t0 = Instant::now();
        let mut l = CycleLedger::default();
        assert_eq!(l.sent(t0, 'a'), 0);
        assert_eq!(l.sent(t0 + p, 'b'), 1);
        assert_eq!(l.overdue(t0 + p, p, 2), None);
        assert_eq!(
            l.overdue(t0 + 2 * p, p, 2),
            Some(Unanswered {
                seq: 0,
                waited: 2 * p
            })
        );
        assert_eq!(l.answered(0), Some('a'));
        assert_eq!(l.answered(0), None, "answered twice");
        assert_eq!(l.overdue(t0 + 2 * p, p, 2), None);
        assert_eq!(l.overdue(t0 + 3 * p, p, 2).map(|u| u.seq), Some(1));
        // An answer to a later command drops an older one still owed (lost on the way).
        l.sent(t0 + 2 * p, 'c');
        assert_eq!(l.answered(2), Some('c'));
        assert_eq!(l.answered(1), None);
        assert_eq!(l.overdue(t0 + 100 * p, p, 2), None);
        assert_eq!(l.count(), 3);
    }
}
