//! Fuzzes the streaming frame generator (`omcbsa_hw::stream::Generator`), which both offline
//! execution and online segments go through: any start, step time, control period, pushes
//! (valid or not) and cycles in between. It must never panic; every command it hands out must
//! pass the limit check after the two before it (re-checked here from the outside, with the
//! hold before the first command); a refused push must leave it as it was; and the queue must
//! stay within its bound.

#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use omcbsa_hw::plan::check_command;
use omcbsa_hw::Command;
use omcbsa_hw::stream::Generator;
use omcbsa_hw::{JointLimits, JOINTS};

/// Bounds on one input's work: waypoints queued ahead, and the cycles a push's check covers.
const MAX_QUEUED: usize = 200;
const MAX_CHECKED_CYCLES: f64 = 20_000.0;

#[derive(Arbitrary, Debug)]
enum Value {
    /// A small step from the previous waypoint: `delta` mrad × `scale`.
    Near { delta: i8, scale: u8 },
    /// Any number at all (NaN, huge, out of limits).
    Raw(f64),
}

#[derive(Arbitrary, Debug)]
enum Op {
    Push {
        /// Start step relative to the fixed waypoint (may be before it or past the end).
        offset: i8,
        waypoints: Vec<Vec<[Value; JOINTS]>>,
    },
    Run {
        cycles: u16,
    },
}

#[derive(Arbitrary, Debug)]
struct Input {
    arms: u8,
    starts: Vec<[Value; JOINTS]>,
    period_us: u16,
    step_us: u32,
    ops: Vec<Op>,
}

fn value(v: &Value, prev: f64) -> f64 {
    match *v {
        Value::Near { delta, scale } => prev + f64::from(delta) * 1e-3 * f64::from(scale % 8),
        Value::Raw(x) => x,
    }
}

fuzz_target!(|input: Input| {
    let limits = omcbsa_mock::testing::arm_limits();
    let arms = usize::from(input.arms % 3) + 1;
    let starts: Vec<[f64; JOINTS]> = (0..arms)
        .map(|a| match input.starts.get(a) {
            Some(q) => std::array::from_fn(|j| value(&q[j], 0.0)),
            None => [0.0; JOINTS],
        })
        .collect();
    let period = f64::from(input.period_us.max(1)) * 1e-6;
    let step_time = f64::from(input.step_us) * 1e-6;
    let Ok(generator) = Generator::new(&starts, limits, period, step_time) else {
        return;
    };
    // As `Executor::online` does with its horizon: a push's check is bounded in cycles.
    let max_queued = (MAX_CHECKED_CYCLES * period / step_time).floor().min(MAX_QUEUED as f64);
    let max_queued = max_queued as usize;
    let mut generator = generator.with_max_queued(max_queued);
    let mut out = vec![[0; JOINTS]; arms];
    let mut prev: Option<Vec<[Command; 2]>> = None;
    let mut budget: u32 = 20_000;
    for op in input.ops.iter().take(32) {
        match op {
            Op::Push { offset, waypoints } => {
                let start = generator.fixed() as i64 + 1 + i64::from(*offset);
                let Ok(start) = usize::try_from(start) else {
                    continue;
                };
                let n = waypoints.first().map_or(0, |w| w.len().min(64));
                let mut last = starts.clone();
                let paths: Vec<Vec<[f64; JOINTS]>> = (0..arms)
                    .map(|a| {
                        let w = waypoints.get(a).map_or(&[][..], |w| &w[..w.len().min(64)]);
                        let len = if a == 0 { n } else { w.len() };
                        (0..len)
                            .map(|i| {
                                let q = std::array::from_fn(|j| match w.get(i) {
                                    Some(v) => value(&v[j], last[a][j]),
                                    None => last[a][j],
                                });
                                last[a] = q;
                                q
                            })
                            .collect()
                    })
                    .collect();
                let slices: Vec<&[[f64; JOINTS]]> = paths.iter().map(|p| p.as_slice()).collect();
                let before = format!("{generator:?}");
                if generator.push(start, &slices).is_err() {
                    assert_eq!(before, format!("{generator:?}"), "a refused push changed the queue");
                }
                assert!(generator.end() - generator.fixed() <= max_queued);
            }
            Op::Run { cycles } => {
                for _ in 0..*cycles {
                    if budget == 0 {
                        return;
                    }
                    budget -= 1;
                    let tick = generator
                        .next(&mut out)
                        .unwrap_or_else(|e| panic!("an accepted queue broke a limit: {e}"));
                    let p = prev.get_or_insert_with(|| out.iter().map(|c| [*c; 2]).collect());
                    for (a, c) in out.iter().enumerate() {
                        check_command(&limits, &p[a][0], &p[a][1], c, period)
                            .unwrap_or_else(|e| panic!("arm {a} cycle {}: {e}", tick.cycle));
                        p[a] = [p[a][1], *c];
                    }
                    if tick.holding {
                        break;
                    }
                }
            }
        }
    }
});
