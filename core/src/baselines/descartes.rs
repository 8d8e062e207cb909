//! PP-Descartes: Descartes-style pose-constrained roadmaps in a prioritised scheme. For every
//! assignment and priority order, each robot in turn samples IK solutions of every pose
//! (layer `t`), connects consecutive layers by edges that respect the velocity limits and are
//! collision-free (also against the robots planned before it), and takes the shortest path
//! through the layers. The next order, then the next assignment, on failure.

use crate::ik::{ik, IkParams};
use crate::model::Models;
use crate::planner::{Horizon, Planner, PlannerKind, Request, Stats, Status, Takes, Until};
use crate::pp::Orders;
use crate::problem::{Robot, Trajectory, MAX_ROBOTS};
use crate::rng::Rng;
use crate::search::{Deadline, OtherArm, OthersMode, Validity};

/// Tunables of PP-Descartes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DescartesParams {
    /// IK samples per pose (roadmap layer width), 1 to 65535.
    pub samples: usize,
    /// The IK projection's settings.
    pub ik: IkParams,
    /// See [`crate::search::OmegaParams::motion_step`].
    pub motion_step: f64,
    /// Seed of the random IK seeds.
    pub seed: u64,
}

impl Default for DescartesParams {
    fn default() -> Self {
        DescartesParams {
            samples: 12,
            ik: IkParams::default(),
            motion_step: crate::motion::MOTION_STEP,
            seed: 0x5eed,
        }
    }
}

/// Roadmap storage: `samples * H` entries each (`samples * H * (8 D + 10) + 2 H` bytes in
/// all). Shorter buffers end planning with `Status::OutOfMemory("Descartes roadmap
/// storage")` before anything is searched.
pub struct DescartesStorage<'a, const D: usize> {
    /// The samples, layer after layer.
    pub layers: &'a mut [[f64; D]],
    /// Each sample's cost to come (joint-space path length).
    pub cost: &'a mut [f64],
    /// Each sample's predecessor in the previous layer.
    pub parent: &'a mut [u16],
    /// Valid samples per layer (H entries).
    pub width: &'a mut [u16],
}

/// PP-Descartes over the caller's roadmap storage. It chooses every start and the assignment
/// itself ([`crate::planner::Takes::FreeOnly`]).
///
/// ```
/// use omcbsa_core::baselines::{Descartes, DescartesParams, DescartesStorage};
/// use omcbsa_core::model::{Frame, KinovaGen3, Model};
/// use omcbsa_core::planner::{NoClock, Planner, Request, Solution, Status, Until};
/// use omcbsa_core::problem::{Problem, Robot, Trajectory};
///
/// const H: usize = 3;
/// const SAMPLES: usize = 4;
/// let mut problem = Problem::<7>::new(0.1);
/// problem.robots.push(Robot::at(0, Frame::IDENTITY)).unwrap();
/// let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
/// problem.trajectories.push(Trajectory::from_slice(&[hand; H]).unwrap()).unwrap();
///
/// // A roadmap of SAMPLES IK solutions per pose.
/// let mut layers = [[0.0; 7]; SAMPLES * H];
/// let (mut cost, mut parent, mut width) = ([0.0; SAMPLES * H], [0; SAMPLES * H], [0; H]);
/// let st = DescartesStorage {
///     layers: &mut layers,
///     cost: &mut cost,
///     parent: &mut parent,
///     width: &mut width,
/// };
/// let params = DescartesParams { samples: SAMPLES, ..DescartesParams::default() };
/// let mut planner = Descartes::new(params, st);
/// let mut paths = [[0.0; 7]; H];
/// let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut paths));
/// assert_eq!(Planner::<KinovaGen3, 7>::solve(&mut planner, &mut req), Status::Solved);
/// for q in req.out.path(0, H) {
///     assert!((KinovaGen3::fk(q).pos - hand.pos).norm() <= problem.tolerance.position);
/// }
/// ```
pub struct Descartes<'a, const D: usize> {
    /// Its settings.
    pub params: DescartesParams,
    st: DescartesStorage<'a, D>,
}

impl<'a, const D: usize> Descartes<'a, D> {
    /// A planner over the caller's roadmap storage.
    pub fn new(params: DescartesParams, st: DescartesStorage<'a, D>) -> Self {
        Descartes { params, st }
    }
}

impl<M: Models<D>, const D: usize> Planner<M, D> for Descartes<'_, D> {
    const TAKES: Takes = Takes::FreeOnly;

    fn kind(&self) -> PlannerKind {
        PlannerKind::Descartes
    }

    fn plan(&mut self, req: &mut Request<'_, D>, h: Horizon) -> Status {
        let (problem, h) = (req.problem, h.get());
        let k = self.params.samples;
        if k == 0 || k > u16::MAX as usize {
            return Status::InvalidProblem("Descartes samples per pose must be 1..=65535");
        }
        let need = k * h;
        if self.st.layers.len() < need
            || self.st.cost.len() < need
            || self.st.parent.len() < need
            || self.st.width.len() < h
        {
            return Status::OutOfMemory("Descartes roadmap storage");
        }
        let n = problem.robots.len();
        let mut orders = Orders::new(n, problem.trajectories.len(), true);
        loop {
            if req.until.expired() {
                return Status::Timeout;
            }
            if self.attempt::<M>(req, h, &orders) {
                return Status::Solved;
            }
            if !orders.advance() {
                return Status::NoSolution;
            }
        }
    }
}

impl<const D: usize> Descartes<'_, D> {
    /// Plans every robot in turn in the priority order and assignment `orders` is at.
    fn attempt<M: Models<D>>(
        &mut self,
        req: &mut Request<'_, D>,
        h: usize,
        orders: &Orders,
    ) -> bool {
        let (problem, deadline) = (req.problem, &req.until);
        let (out, stats) = (&mut req.out, &mut req.stats);
        let n = problem.robots.len();
        for (rank, &r) in orders.order[..n].iter().enumerate() {
            let r = r as usize;
            let robot = problem.robots[r];
            let mut others: heapless::Vec<OtherArm<'_, D>, MAX_ROBOTS> = heapless::Vec::new();
            for &o in &orders.order[..rank] {
                let o = o as usize;
                let _ = others.push(OtherArm {
                    model: problem.robots[o].model,
                    base: problem.robots[o].base,
                    tool: problem.robots[o].tool,
                    path: &out.paths[o * h..(o + 1) * h],
                });
            }
            let valid = Validity::<M, D>::new(
                &robot,
                &problem.obstacles,
                problem.dt,
                self.params.motion_step,
            )
            .with_others(&others, OthersMode::Avoid);
            stats.low_level_calls += 1;
            let traj = orders.trajectory_of(r);
            let end = match traj {
                Some(j) => self.roadmap::<M>(
                    &robot,
                    &problem.trajectories[j],
                    &valid,
                    (r, j),
                    deadline,
                    stats,
                ),
                None => robot
                    .initial
                    .filter(|q| valid.hold(q, h).is_some())
                    .map(|q| {
                        self.st.layers[..h].iter_mut().for_each(|l| *l = q);
                        usize::MAX
                    }),
            };
            drop(others);
            let Some(end) = end else { return false };
            self.write_path(h, end, &mut out.paths[r * h..(r + 1) * h]);
            out.assignment[r] = traj.map(|j| j as u8);
        }
        true
    }

    /// Builds the roadmap of one robot on one trajectory and searches it; returns the index in
    /// the last layer of the best path's end (or `None` if the layers do not connect).
    fn roadmap<M: Models<D>>(
        &mut self,
        robot: &Robot<D>,
        traj: &Trajectory,
        valid: &Validity<'_, M, D>,
        (r, j): (usize, usize),
        deadline: &Until<'_>,
        stats: &mut Stats,
    ) -> Option<usize> {
        let k = self.params.samples;
        let h = traj.len();
        let target = robot.ik_target();
        let mut rng = Rng::new(self.params.seed ^ ((r as u64) << 32 | j as u64));
        for t in 0..h {
            if deadline.expired() {
                return None;
            }
            let goal = target(&traj[t]);
            let mut width = 0usize;
            // Seeds: projections of the previous layer's samples (so layers can connect), then
            // random configurations; `initial` first on the first layer.
            let prev = if t == 0 {
                0
            } else {
                self.st.width[t - 1] as usize
            };
            let mut attempt = 0usize;
            while width < k && attempt < 3 * k {
                let seed = if t == 0 && attempt == 0 && robot.initial.is_some() {
                    robot.initial.unwrap_or([0.0; D])
                } else if attempt < prev {
                    self.st.layers[(t - 1) * k + attempt]
                } else {
                    rng.configuration(M::lower(robot.model), M::upper(robot.model))
                };
                attempt += 1;
                let Ok(q) = ik::<M, D>(robot.model, &goal, &seed, &self.params.ik) else {
                    continue;
                };
                if valid.state(&q, t).is_none() {
                    continue;
                }
                let i = t * k + width;
                self.st.layers[i] = q;
                self.st.cost[i] = f64::INFINITY;
                width += 1;
                stats.expansions += 1;
            }
            self.st.width[t] = width as u16;
            if width == 0 {
                return None;
            }
            // Edges from the previous layer; shortest path by joint-space length.
            for b in 0..width {
                let ib = t * k + b;
                if t == 0 {
                    self.st.cost[ib] = 0.0;
                    continue;
                }
                for a in 0..prev {
                    let ia = (t - 1) * k + a;
                    if !self.st.cost[ia].is_finite() {
                        continue;
                    }
                    let (qa, qb) = (self.st.layers[ia], self.st.layers[ib]);
                    if !valid.step_within_limits(&qa, &qb) {
                        continue;
                    }
                    let d: f64 = (0..D)
                        .map(|x| (qb[x] - qa[x]) * (qb[x] - qa[x]))
                        .sum::<f64>();
                    let c = self.st.cost[ia] + libm::sqrt(d);
                    if c < self.st.cost[ib] && valid.motion(&qa, &qb, t - 1).is_some() {
                        self.st.cost[ib] = c;
                        self.st.parent[ib] = a as u16;
                    }
                }
            }
        }
        let last = (h - 1) * k;
        (0..self.st.width[h - 1] as usize)
            .filter(|&b| self.st.cost[last + b].is_finite())
            .min_by(|&a, &b| self.st.cost[last + a].total_cmp(&self.st.cost[last + b]))
    }

    /// Copies the path ending at `end` of the last layer into `out` (`usize::MAX`: the hold
    /// path stored in the first `H` layer entries).
    fn write_path(&self, h: usize, end: usize, out: &mut [[f64; D]]) {
        if end == usize::MAX {
            out.copy_from_slice(&self.st.layers[..h]);
            return;
        }
        let k = self.params.samples;
        let mut b = end;
        for t in (0..h).rev() {
            out[t] = self.st.layers[t * k + b];
            b = self.st.parent[t * k + b] as usize;
        }
    }
}
