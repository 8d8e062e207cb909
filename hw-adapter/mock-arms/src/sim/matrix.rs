//! The fault matrix at the default rates: three simulated arms of one transport stream a plan
//! with the command line's default watchdog, one of them injects a fault, and the arms' own
//! records say how many control periods passed from the fault's first sign to each arm's stop
//! ([`Outcome::periods_to_stop`]). The tests (tests/watchdog_bound.rs) and the measuring
//! command (examples/fault_matrix.rs) both run it.

use super::can::{self, CanSim, CanSimOptions};
use super::kortex::{self, KortexSim, KortexSimOptions};
use super::SimRecord;
use omcbsa_hw::plan::{ArmPlan, Plan, PlanValidator};
use omcbsa_hw::port::ArmPort;
use omcbsa_hw::run::{CycleFault, ExecConfig, ExecError, Fault, FaultReport, Report, JOINTS};
use omcbsa_hw::Executor;
use std::time::Duration;

/// The arms of a matrix run; the fault is injected on [`FAULTY_ARM`].
pub const ARMS: [&str; 3] = ["left", "right", "middle"];
/// The arm that faults.
pub const FAULTY_ARM: &str = "right";
/// The cycle (SYNC or Refresh, counted by the arm from its first) the fault starts at.
pub const FAULT_AT: u64 = 40;

/// A transport, with its default control period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Link {
    /// CiA 402 drives on CAN, one 1 Mbit/s in-process bus per arm, at
    /// [`omcbsa_hw::bus::CAN_PERIOD`] (4 ms).
    Can,
    /// A Gen3 on Kortex, at 1 ms.
    Kortex,
}

impl Link {
    /// The transport's default control period (the command line's).
    pub fn period(self) -> Duration {
        match self {
            Link::Can => omcbsa_hw::bus::CAN_PERIOD,
            Link::Kortex => Duration::from_millis(1),
        }
    }

    /// Its name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Link::Can => "CAN (4 ms)",
            Link::Kortex => "Kortex (1 ms)",
        }
    }
}

/// A row of the matrix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MatrixFault {
    /// The arm answers nothing more.
    Silence,
    /// Every answer from the fault on comes this many periods late.
    Late(u32),
    /// Kortex: every Refresh answered with an error frame.
    ErrorFrame,
    /// CAN: a drive's EMCY.
    Emcy,
    /// A drive's statusword (CAN) or an actuator's fault bank (Kortex) reports a fault.
    FaultBit,
    /// Kortex: the arm forgets its sessions; CAN: a drive goes to NMT stopped.
    LostSession,
}

impl MatrixFault {
    /// Every row, in the table's order.
    pub const ALL: [MatrixFault; 7] = [
        MatrixFault::Silence,
        MatrixFault::Late(1),
        MatrixFault::Late(20),
        MatrixFault::ErrorFrame,
        MatrixFault::Emcy,
        MatrixFault::FaultBit,
        MatrixFault::LostSession,
    ];

    /// Its name in the table.
    pub fn name(self) -> String {
        match self {
            MatrixFault::Silence => "silence".into(),
            MatrixFault::Late(n) => {
                format!("answers {n} period{} late", if n == 1 { "" } else { "s" })
            }
            MatrixFault::ErrorFrame => "error frame".into(),
            MatrixFault::Emcy => "EMCY".into(),
            MatrixFault::FaultBit => "fault bit".into(),
            MatrixFault::LostSession => "lost session / NMT stop".into(),
        }
    }

    /// Whether the watchdog must stop the run for it. Answers late by less than
    /// [`omcbsa_hw::WatchSettings::missed_cycles`] periods are within its bound by design, so a
    /// run with them may complete; it stops when the loop's own jitter takes one of them past
    /// the bound (the stop's bound then holds from that answer's cycle).
    pub fn is_fault(self, cfg: &ExecConfig) -> bool {
        !matches!(self, MatrixFault::Late(n) if n < cfg.watch.missed_cycles)
    }

    fn can(self, period: Duration) -> Option<can::Injected> {
        Some(match self {
            MatrixFault::Silence => can::Injected::Silence,
            MatrixFault::Late(n) => can::Injected::Late(period * n),
            MatrixFault::Emcy => can::Injected::Emcy,
            MatrixFault::FaultBit => can::Injected::FaultBit,
            MatrixFault::LostSession => can::Injected::NmtStop,
            MatrixFault::ErrorFrame => return None,
        })
    }

    fn kortex(self, period: Duration) -> Option<kortex::Injected> {
        Some(match self {
            MatrixFault::Silence => kortex::Injected::Silence,
            MatrixFault::Late(n) => kortex::Injected::Late(period * n),
            MatrixFault::ErrorFrame => kortex::Injected::ErrorFrame,
            MatrixFault::FaultBit => kortex::Injected::FaultBit,
            MatrixFault::LostSession => kortex::Injected::LostSession,
            MatrixFault::Emcy => return None,
        })
    }

    /// Whether `link` has this fault (EMCY is CANopen's, error frames and sessions Kortex's).
    pub fn applies_to(self, link: Link) -> bool {
        match link {
            Link::Can => self.can(Duration::ZERO).is_some(),
            Link::Kortex => self.kortex(Duration::ZERO).is_some(),
        }
    }
}

/// What a matrix run gave.
#[derive(Debug)]
pub struct Outcome {
    /// The run's end: its report, or the fault that stopped it.
    pub result: Result<Report, Box<FaultReport>>,
    /// What each arm saw, in [`ARMS`] order.
    pub records: Vec<SimRecord>,
    /// The control period.
    pub period: Duration,
}

impl Outcome {
    /// Whether the run stopped before the fault was injected (the machine held the loop up
    /// past the watchdog's bound: a stop by the watchdog, but not of the injected fault).
    pub fn stopped_before_the_fault(&self) -> bool {
        self.result.is_err() && self.faulty().first_sign.is_none()
    }

    /// The faulty arm's record.
    pub fn faulty(&self) -> &SimRecord {
        let i = ARMS.iter().position(|a| *a == FAULTY_ARM).unwrap_or(0);
        &self.records[i]
    }

    /// The fault's first sign, on the faulty arm's clock: for a cycle unanswered or answered
    /// late, when that cycle's command reached the arm (the first of them that broke the
    /// accounting, as the fault names it); for the others, the arm's own record of it.
    pub fn first_sign(&self) -> Option<std::time::Instant> {
        match &self.result {
            Err(r) => match r.fault {
                Fault::Answer {
                    fault: CycleFault::Missing { cycle, .. } | CycleFault::Late { cycle, .. },
                    ..
                } if r.arm == FAULTY_ARM => self
                    .faulty()
                    .cycle_times
                    .get(usize::try_from(cycle).ok()?)
                    .copied(),
                _ => self.faulty().first_sign,
            },
            Ok(_) => self.faulty().first_sign,
        }
    }

    /// Per arm, control periods from the fault's first sign ([`Outcome::first_sign`]) to the
    /// arm's stop (`None` for an arm not stopped, or without a first sign).
    pub fn periods_to_stop(&self) -> Vec<Option<f64>> {
        let sign = self.first_sign();
        (self.records.iter())
            .map(|r| {
                let (sign, stop) = (sign?, r.stopped?);
                Some(stop.saturating_duration_since(sign).as_secs_f64() / self.period.as_secs_f64())
            })
            .collect()
    }
}

struct Accept;

impl PlanValidator for Accept {
    fn validate(&self, _: &Plan) -> Result<(), String> {
        Ok(())
    }
}

/// A smooth plan of `seconds` for the three arms, within the Gen3's limits as planned.
pub fn plan(seconds: f64) -> Plan {
    let dt = 0.25;
    let steps = (seconds / dt).ceil().max(1.0) as usize;
    Plan {
        dt,
        arms: (ARMS.iter().enumerate())
            .map(|(a, name)| ArmPlan {
                name: name.to_string(),
                joint_path: (0..=steps)
                    .map(|i| {
                        let s = (i as f64 / steps as f64 * std::f64::consts::PI).sin();
                        std::array::from_fn(|j| 0.1 * a as f64 - 0.1 + 0.02 * s * (j as f64 - 3.0))
                    })
                    .collect(),
            })
            .collect(),
    }
}

/// Runs `plan` on three simulated arms of `link` with `cfg`, the arm [`FAULTY_ARM`] injecting
/// `fault` at [`FAULT_AT`] (none: a plain run).
pub fn run(
    link: Link,
    fault: Option<MatrixFault>,
    plan: &Plan,
    cfg: &ExecConfig,
) -> Result<Outcome, String> {
    let limits = crate::testing::fleet_limits(plan.arms.len());
    let mut finish: Vec<Box<dyn FnOnce() -> SimRecord>> = Vec::new();
    let mut ports: Vec<(String, ArmPort)> = Vec::new();
    for arm in &plan.arms {
        let start: [f64; JOINTS] = arm.joint_path[0];
        let faulty = arm.name == FAULTY_ARM;
        let inject = |f: Option<MatrixFault>| f.filter(|_| faulty);
        let port = match link {
            Link::Can => {
                let injected = match inject(fault) {
                    Some(f) => Some((FAULT_AT, f.can(cfg.period).ok_or("no such CAN fault")?)),
                    None => None,
                };
                let (sim, bus) = CanSim::spawn(CanSimOptions {
                    fault: injected,
                    ..CanSimOptions::at(start)
                });
                finish.push(Box::new(move || sim.finish()));
                ArmPort::from(bus)
            }
            Link::Kortex => {
                let injected = match inject(fault) {
                    Some(f) => Some((
                        FAULT_AT,
                        f.kortex(cfg.period).ok_or("no such Kortex fault")?,
                    )),
                    None => None,
                };
                let (sim, conn) = KortexSim::spawn(KortexSimOptions {
                    fault: injected,
                    ..KortexSimOptions::at(start)
                })?;
                finish.push(Box::new(move || sim.finish()));
                ArmPort::from(conn)
            }
        };
        ports.push((arm.name.clone(), port));
    }
    let result = match Executor::new(plan.clone(), limits, ports, cfg.clone()) {
        Ok(e) => e.run(&Accept),
        Err(e) => Err(e),
    };
    let records = finish.into_iter().map(|f| f()).collect();
    let result = match result {
        Ok(report) => Ok(report),
        Err(ExecError::Fault(r)) => Err(r),
        Err(e) => return Err(e.to_string()),
    };
    Ok(Outcome {
        result,
        records,
        period: cfg.period,
    })
}
