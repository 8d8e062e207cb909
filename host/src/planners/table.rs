//! The one table of planners, [`PLANNERS`]: for each [`PlannerKind`], the storage it takes
//! from the arena and how it runs on it. The arena is measured from the same entries, so a
//! planner is added by one entry here (docs/ARCHITECTURE.md, "Adding a planner").

use super::arena::{Cut, Lengths, Short, Take};
use super::capacity::{Capacities, START_CACHE_ENTRIES};
use crate::models::Fleet;
use crate::models::DOF;
use omcbsa_core::approach::ApproachStorage;
use omcbsa_core::baselines::{
    CompositeAstar, CompositeParams, CompositeStorage, Descartes, DescartesParams,
    DescartesStorage, IkTracking, IkTrackingParams,
};
use omcbsa_core::cbs::{CbsParams, CbsStorage, OmegaCbsa};
use omcbsa_core::embody::{run_planner, solve_from_initial, Embodied, Embodiment};
use omcbsa_core::planner::{Planner, PlannerKind, Status};
use omcbsa_core::pp::{PpStorage, Prioritized, Variant};
use omcbsa_core::problem::MAX_ROBOTS;
use omcbsa_core::search::{Node, OpenEntry, Slot, Workspace, WorkspaceError};

/// What an entry sizes and sets its planner by, besides the arena.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// The pools' sizes.
    pub caps: Capacities,
    /// The horizon: the problem's when running, the longest planned when measuring.
    pub h: usize,
    /// Ω-CBSA's settings (its low level's are the prioritised planners').
    pub cbs: CbsParams,
    /// Whether the approach from `initial` is planned with the plan.
    pub with_approach: bool,
}

/// Why a planner's storage could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StorageError {
    /// A slab of the arena is shorter than the planner's storage.
    Short(Short),
    /// Ω-A*'s workspace refused its buffers.
    Workspace(WorkspaceError),
    /// The planner has no entry in [`PLANNERS`].
    NoEntry(PlannerKind),
}

impl From<Short> for StorageError {
    fn from(e: Short) -> Self {
        StorageError::Short(e)
    }
}

impl From<WorkspaceError> for StorageError {
    fn from(e: WorkspaceError) -> Self {
        StorageError::Workspace(e)
    }
}

impl std::fmt::Display for StorageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StorageError::Short(s) => write!(f, "{s}"),
            StorageError::Workspace(e) => write!(f, "search workspace: {e:?}"),
            StorageError::NoEntry(kind) => write!(f, "no storage entry for {}", kind.name()),
        }
    }
}

/// How a planner's entry ended: how the run went, or `None` when the cut was only measuring.
pub type Ended = Result<Option<Embodied>, StorageError>;

/// One planner: takes its storage from `cut` and runs on `req` there. Without a request the
/// cut is measuring (it hands out empty slices and counts them) and nothing runs.
pub struct Entry {
    /// The planner.
    pub kind: PlannerKind,
    /// Its storage and its run.
    pub run: fn(&mut Cut<'_>, &Settings, Option<&mut Embodiment<'_, DOF>>) -> Ended,
}

/// Every planner, its storage and its run.
pub static PLANNERS: [Entry; 7] = [
    Entry {
        kind: PlannerKind::OmCbsa,
        run: |cut, s, req| {
            let (nodes, open, table) = search(cut, &s.caps)?;
            let st = CbsStorage {
                nodes: cut.take(s.caps.ct_nodes)?,
                open: cut.take(s.caps.ct_nodes)?,
                // The same number of paths whatever horizon the arena was made for, so that
                // every caller (plan, bench, Python) gets the same search.
                paths: cut.take(s.caps.path_slots * s.h)?,
                scratch: cut.take(s.h)?,
                points: cut.take(s.caps.constraints)?,
                starts: cut.take(START_CACHE_ENTRIES)?,
            };
            go(req, s, || {
                Ok(OmegaCbsa::new(
                    s.cbs,
                    Workspace::new(nodes, open, table)?,
                    st,
                ))
            })
        },
    },
    Entry {
        kind: PlannerKind::Pp,
        run: |cut, s, req| prioritized(Variant::MultiGoal, cut, s, req),
    },
    Entry {
        kind: PlannerKind::PpSingle,
        run: |cut, s, req| prioritized(Variant::SingleGoal, cut, s, req),
    },
    Entry {
        kind: PlannerKind::IkTracking,
        run: |_, s, req| {
            go(req, s, || {
                Ok(IkTracking {
                    params: IkTrackingParams::default(),
                })
            })
        },
    },
    Entry {
        kind: PlannerKind::Descartes,
        run: |cut, s, req| {
            let k = s.caps.descartes_samples * s.h;
            let st = DescartesStorage {
                layers: cut.take(k)?,
                cost: cut.take(k)?,
                parent: cut.take(k)?,
                width: cut.take(s.h)?,
            };
            let params = DescartesParams {
                samples: s.caps.descartes_samples,
                ..DescartesParams::default()
            };
            go(req, s, || Ok(Descartes::new(params, st)))
        },
    },
    Entry {
        kind: PlannerKind::CompositeAstar,
        run: |cut, s, req| {
            let st = CompositeStorage {
                nodes: cut.take(s.caps.composite_nodes)?,
                open: cut.take(open_entries(&s.caps))?,
            };
            go(req, s, || {
                Ok(CompositeAstar::new(CompositeParams::default(), st))
            })
        },
    },
    Entry {
        kind: PlannerKind::OmegaAstar,
        // Ω-A* alone is prioritised planning with one robot.
        run: |cut, s, req| match req {
            Some(req) if req.problem.robots.len() != 1 => Ok(Some(Embodied::ended(
                Status::InvalidProblem(
                    "omega-astar plans one robot; use omcbsa, pp or pp-single for several",
                ),
                0,
            ))),
            req => prioritized(Variant::MultiGoal, cut, s, req),
        },
    },
];

/// `kind`'s entry.
pub fn entry(kind: PlannerKind) -> Result<&'static Entry, StorageError> {
    (PLANNERS.iter().find(|e| e.kind == kind)).ok_or(StorageError::NoEntry(kind))
}

/// What the approach loop around every planner takes: RRT-Connect's trees and their parents,
/// and the waypoints.
pub fn approach_storage<'a>(
    cut: &mut Cut<'a>,
    caps: &Capacities,
) -> Result<ApproachStorage<'a, DOF>, Short> {
    Ok(ApproachStorage {
        tree: cut.take(caps.approach_nodes * MAX_ROBOTS)?,
        parent: cut.take(caps.approach_nodes)?,
        waypoints: cut.take(caps.approach_waypoints * MAX_ROBOTS)?,
    })
}

/// The arena every planner's run fits in, for horizons up to `max_h`: slab by slab, the most
/// that the approach and any one planner take.
pub fn measure(caps: Capacities, max_h: usize) -> Result<Lengths, StorageError> {
    let s = Settings {
        caps,
        h: max_h,
        cbs: CbsParams::default(),
        with_approach: true,
    };
    PLANNERS.iter().try_fold(Lengths::default(), |most, e| {
        let mut cut = Cut::measuring();
        approach_storage(&mut cut, &caps)?;
        (e.run)(&mut cut, &s, None)?;
        Ok(most.max(cut.taken()))
    })
}

/// Runs the planner `make` builds on `req`, with the approach from where the arms stand when
/// `s.with_approach` (else the planner alone, its plan beginning wherever it chose); nothing
/// when measuring.
fn go<P: Planner<Fleet, DOF>>(
    req: Option<&mut Embodiment<'_, DOF>>,
    s: &Settings,
    make: impl FnOnce() -> Result<P, StorageError>,
) -> Ended {
    let Some(req) = req else {
        return Ok(None);
    };
    let mut planner = make()?;
    Ok(Some(if s.with_approach {
        solve_from_initial::<Fleet, P, DOF>(&mut planner, req)
    } else {
        Embodied::ended(run_planner::<Fleet, P, DOF>(&mut planner, req), 1)
    }))
}

/// OPEN entries of a search: twice its nodes.
fn open_entries(caps: &Capacities) -> usize {
    2 * caps.search_nodes
}

/// Ω-A*'s buffers: nodes, OPEN entries and a duplicate table (a power of two).
type SearchBuffers<'a> = (&'a mut [Node<DOF>], &'a mut [OpenEntry], &'a mut [Slot]);

fn search<'a>(cut: &mut Cut<'a>, caps: &Capacities) -> Result<SearchBuffers<'a>, Short> {
    Ok((
        cut.take(caps.search_nodes)?,
        cut.take(open_entries(caps))?,
        cut.take(open_entries(caps).next_power_of_two())?,
    ))
}

/// The prioritised planners (Ω-A* alone among them).
fn prioritized(
    variant: Variant,
    cut: &mut Cut<'_>,
    s: &Settings,
    req: Option<&mut Embodiment<'_, DOF>>,
) -> Ended {
    let (nodes, open, table) = search(cut, &s.caps)?;
    let st = PpStorage {
        scratch: cut.take(s.h)?,
        starts: cut.take(START_CACHE_ENTRIES)?,
    };
    // Ω-A*'s settings are Ω-CBSA's low level's, so both plan alike online.
    go(req, s, || {
        Ok(Prioritized::new(
            variant,
            s.cbs.low,
            Workspace::new(nodes, open, table)?,
            st,
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_planner_has_one_entry() {
        for kind in PlannerKind::ALL {
            let n = PLANNERS.iter().filter(|e| e.kind == kind).count();
            assert_eq!(n, 1, "{} has {n} entries", kind.name());
        }
    }
}
