//! Composite A*: A* over joint states `(q^1, ..., q^N, t)` of all robots. A state's successors
//! are the Cartesian product of every robot's Ω-A* successors (IK projection and null-space
//! moves) at `t + 1`, kept when no two robots collide. OPEN starts with combinations of IK
//! solutions of every robot's first pose under every assignment. There is no duplicate
//! detection: joint states almost never repeat, and the branching factor (up to `3^N` for
//! 7-joint arms) is what makes this baseline scale poorly with the number of robots.

use crate::collision::ArmPose;
use crate::ik::{ik_multi_start, MultiStart};
use crate::model::{Frame, Models};
use crate::motion::{motions_collide, ArmMotion};
use crate::planner::{
    Horizon, Planner, PlannerKind, Request, Solution, Stats, Status, Takes, Until,
};
use crate::pp::Orders;
use crate::problem::{Problem, MAX_ROBOTS};
use crate::rng::Rng;
use crate::search::{
    manifold_moves, Deadline, OmegaParams, OpenEntry, OpenList, Validity, MAX_MOVES,
};

/// Tunables of composite A*.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompositeParams {
    /// ε, w_h, IK settings and motion checks as in Ω-A*.
    pub low: OmegaParams,
    /// IK solutions of the first pose per robot and trajectory.
    pub start_solutions: usize,
    /// Most initial joint states per assignment.
    pub max_starts: usize,
}

impl Default for CompositeParams {
    fn default() -> Self {
        CompositeParams {
            low: OmegaParams::default(),
            start_solutions: 2,
            max_starts: 16,
        }
    }
}

/// One joint state.
#[derive(Clone, Copy, Debug)]
pub struct CompositeNode<const D: usize> {
    q: [[f64; D]; MAX_ROBOTS],
    g: f64,
    parent: u32,
    t: u16,
    /// Trajectory of each robot (`u8::MAX`: holds).
    assign: [u8; MAX_ROBOTS],
}

impl<const D: usize> Default for CompositeNode<D> {
    fn default() -> Self {
        CompositeNode {
            q: [[0.0; D]; MAX_ROBOTS],
            g: 0.0,
            parent: u32::MAX,
            t: 0,
            assign: [u8::MAX; MAX_ROBOTS],
        }
    }
}

/// Composite A* over the caller's storage ([`CompositeStorage`]). A full pool ends planning
/// with `Status::OutOfMemory` naming it. It chooses every start and the assignment itself
/// ([`crate::planner::Takes::FreeOnly`]).
///
/// ```
/// use omcbsa_core::baselines::{CompositeAstar, CompositeNode};
/// use omcbsa_core::baselines::{CompositeParams, CompositeStorage};
/// use omcbsa_core::model::{Frame, KinovaGen3, Model};
/// use omcbsa_core::planner::{NoClock, Planner, Request, Solution, Status, Until};
/// use omcbsa_core::problem::{Problem, Robot, Trajectory};
/// use omcbsa_core::search::OpenEntry;
///
/// const H: usize = 3;
/// let mut problem = Problem::<7>::new(0.1);
/// problem.robots.push(Robot::at(0, Frame::IDENTITY)).unwrap();
/// let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
/// problem.trajectories.push(Trajectory::from_slice(&[hand; H]).unwrap()).unwrap();
///
/// let mut nodes = [CompositeNode::<7>::default(); 64];
/// let mut open = [OpenEntry::default(); 64];
/// let st = CompositeStorage { nodes: &mut nodes, open: &mut open };
/// let mut planner = CompositeAstar::new(CompositeParams::default(), st);
/// let mut paths = [[0.0; 7]; H];
/// let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut paths));
/// assert_eq!(Planner::<KinovaGen3, 7>::solve(&mut planner, &mut req), Status::Solved);
/// assert_eq!(req.out.assignment[0], Some(0));
///
/// // Too few nodes for even the start states: the pool is named, nothing panics.
/// let (mut one, mut open) = ([CompositeNode::<7>::default(); 1], [OpenEntry::default(); 1]);
/// let st = CompositeStorage { nodes: &mut one, open: &mut open };
/// let mut small = CompositeAstar::new(CompositeParams::default(), st);
/// let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut paths));
/// let status = Planner::<KinovaGen3, 7>::solve(&mut small, &mut req);
/// assert_eq!(status, Status::OutOfMemory("composite A* node pool"));
/// ```
pub struct CompositeAstar<'a, const D: usize> {
    /// Its settings.
    pub params: CompositeParams,
    st: CompositeStorage<'a, D>,
}

/// Caller storage of composite A*: joint-state nodes (about 500 bytes each for `D = 7`,
/// whatever the number of robots) and an OPEN list (16 bytes an entry; as many as the nodes
/// is ample).
pub struct CompositeStorage<'a, const D: usize> {
    /// The node pool.
    pub nodes: &'a mut [CompositeNode<D>],
    /// The OPEN list.
    pub open: &'a mut [OpenEntry],
}

impl<'a, const D: usize> CompositeAstar<'a, D> {
    /// A planner over the caller's node pool and OPEN list.
    pub fn new(params: CompositeParams, st: CompositeStorage<'a, D>) -> Self {
        CompositeAstar { params, st }
    }
}

impl<M: Models<D>, const D: usize> Planner<M, D> for CompositeAstar<'_, D> {
    const TAKES: Takes = Takes::FreeOnly;

    fn kind(&self) -> PlannerKind {
        PlannerKind::CompositeAstar
    }

    fn plan(&mut self, req: &mut Request<'_, D>, h: Horizon) -> Status {
        let problem = req.problem;
        let mut search = Search::<M, D> {
            pr: problem,
            p: &self.params,
            nodes: &mut *self.st.nodes,
            used: 0,
            open: OpenList::new(&mut *self.st.open),
            h: h.get(),
            n: problem.robots.len(),
            deadline: req.until,
            stats: &mut req.stats,
            _m: core::marker::PhantomData,
        };
        search.run(&mut req.out)
    }
}

struct Search<'r, M, const D: usize> {
    pr: &'r Problem<D>,
    p: &'r CompositeParams,
    nodes: &'r mut [CompositeNode<D>],
    used: usize,
    open: OpenList<'r>,
    h: usize,
    n: usize,
    deadline: Until<'r>,
    stats: &'r mut Stats,
    _m: core::marker::PhantomData<M>,
}

impl<M: Models<D>, const D: usize> Search<'_, M, D> {
    fn run(&mut self, out: &mut Solution<'_, D>) -> Status {
        if let Err(s) = self.seed() {
            return s;
        }
        let mut since = 0u32;
        while let Some(e) = self.open.pop() {
            since += 1;
            if since.is_multiple_of(16) && self.deadline.expired() {
                return Status::Timeout;
            }
            let node = self.nodes[e.node as usize];
            if node.t as usize == self.h - 1 {
                self.write(e.node, out);
                return Status::Solved;
            }
            self.stats.expansions += 1;
            if let Err(s) = self.expand(e.node, &node) {
                return s;
            }
        }
        Status::NoSolution
    }

    fn validity(&self, r: usize) -> Validity<'_, M, D> {
        let (robot, pr) = (&self.pr.robots[r], self.pr);
        Validity::new(robot, &pr.obstacles, pr.dt, self.p.low.motion_step)
    }

    fn target(&self, r: usize, j: usize, t: usize) -> Frame {
        self.pr.robots[r].ik_target()(&self.pr.trajectories[j][t])
    }

    fn push(&mut self, node: CompositeNode<D>) -> Result<(), Status> {
        if self.used == self.nodes.len() {
            return Err(Status::OutOfMemory("composite A* node pool"));
        }
        let id = self.used as u32;
        self.nodes[self.used] = node;
        self.used += 1;
        let f = node.g + self.p.low.w_h * (self.h - 1 - node.t as usize) as f64;
        if self.open.push(OpenEntry {
            f,
            t: node.t as u32,
            node: id,
        }) {
            Ok(())
        } else {
            Err(Status::OutOfMemory("composite A* open list"))
        }
    }

    /// Initial joint states: for every assignment, combinations of the robots' first-pose IK
    /// solutions (or `initial` for holding robots) in which no two robots collide.
    fn seed(&mut self) -> Result<(), Status> {
        let mut orders = Orders::new(self.n, self.pr.trajectories.len(), true);
        let multi = MultiStart {
            attempts: self.p.low.start_attempts,
            min_separation: 0.1,
        };
        loop {
            let mut sols = [[[0.0; D]; 4]; MAX_ROBOTS];
            let mut counts = [0usize; MAX_ROBOTS];
            let mut node = CompositeNode::<D>::default();
            for r in 0..self.n {
                let valid = self.validity(r);
                match orders.trajectory_of(r) {
                    Some(j) => {
                        node.assign[r] = j as u8;
                        let mut rng = Rng::new(self.p.low.seed ^ ((r as u64) << 32 | j as u64));
                        let want = self.p.start_solutions.clamp(1, 4);
                        let mut found = [[0.0; D]; 4];
                        let k = ik_multi_start::<M, D>(
                            self.pr.robots[r].model,
                            &self.target(r, j, 0),
                            &self.p.low.ik,
                            &multi,
                            &mut rng,
                            &mut found[..want],
                        )
                        .unwrap_or(0);
                        for q in &found[..k] {
                            if valid.state(q, 0).is_some() {
                                sols[r][counts[r]] = *q;
                                counts[r] += 1;
                            }
                        }
                    }
                    None => {
                        if let Some(q) = self.pr.robots[r]
                            .initial
                            .filter(|q| valid.state(q, 0).is_some())
                        {
                            sols[r][0] = q;
                            counts[r] = 1;
                        }
                    }
                }
            }
            let mut digits = [0usize; MAX_ROBOTS];
            let mut starts = 0;
            if counts[..self.n].iter().all(|&c| c > 0) {
                loop {
                    for r in 0..self.n {
                        node.q[r] = sols[r][digits[r]];
                    }
                    if self.robots_clear(&node.q) {
                        self.push(node)?;
                        starts += 1;
                    }
                    if starts == self.p.max_starts
                        || !next_digits(&mut digits[..self.n], &counts[..self.n])
                    {
                        break;
                    }
                }
            }
            if self.deadline.expired() {
                return Err(Status::Timeout);
            }
            if !orders.next_assignment() {
                return Ok(());
            }
        }
    }

    fn robots_clear(&self, q: &[[f64; D]; MAX_ROBOTS]) -> bool {
        let robots = &self.pr.robots[..self.n];
        for (i, (ri, qi)) in robots.iter().zip(q).enumerate() {
            let a = ArmPose::new::<M, D>(ri.model, &ri.base, &ri.tool, qi);
            for (rk, qk) in robots.iter().zip(q).skip(i + 1) {
                if a.arm_hit(&ArmPose::new::<M, D>(rk.model, &rk.base, &rk.tool, qk), 0.0)
                    .is_some()
                {
                    return false;
                }
            }
        }
        true
    }

    fn expand(&mut self, id: u32, node: &CompositeNode<D>) -> Result<(), Status> {
        let t1 = node.t as usize + 1;
        let mut moves = [[[0.0; D]; MAX_MOVES]; MAX_ROBOTS];
        let mut counts = [0usize; MAX_ROBOTS];
        for r in 0..self.n {
            let q = &node.q[r];
            if node.assign[r] == u8::MAX {
                moves[r][0] = *q;
                counts[r] = 1;
                continue;
            }
            let valid = self.validity(r);
            let mut cand = [[0.0; D]; MAX_MOVES];
            let k = manifold_moves::<M, D>(
                self.pr.robots[r].model,
                &self.target(r, node.assign[r] as usize, t1),
                q,
                &self.p.low,
                &mut cand,
            );
            for c in &cand[..k] {
                if valid.step_within_limits(q, c)
                    && valid.state(c, t1).is_some()
                    && valid.motion(q, c, node.t as usize).is_some()
                {
                    moves[r][counts[r]] = *c;
                    counts[r] += 1;
                }
            }
            if counts[r] == 0 {
                return Ok(());
            }
        }
        let mut digits = [0usize; MAX_ROBOTS];
        loop {
            let mut child = *node;
            child.parent = id;
            child.t = t1 as u16;
            let mut g = node.g;
            for r in 0..self.n {
                child.q[r] = moves[r][digits[r]];
                let d2: f64 = (0..D)
                    .map(|x| (child.q[r][x] - node.q[r][x]) * (child.q[r][x] - node.q[r][x]))
                    .sum();
                g += libm::sqrt(d2);
            }
            child.g = g;
            if self.robots_clear(&child.q) && self.motions_clear(&node.q, &child.q) {
                self.push(child)?;
            }
            if !next_digits(&mut digits[..self.n], &counts[..self.n]) {
                return Ok(());
            }
        }
    }

    fn motions_clear(&self, from: &[[f64; D]; MAX_ROBOTS], to: &[[f64; D]; MAX_ROBOTS]) -> bool {
        for i in 0..self.n {
            let a = ArmMotion {
                model: self.pr.robots[i].model,
                base: &self.pr.robots[i].base,
                tool: &self.pr.robots[i].tool,
                from: &from[i],
                to: &to[i],
            };
            for k in i + 1..self.n {
                let b = ArmMotion {
                    model: self.pr.robots[k].model,
                    base: &self.pr.robots[k].base,
                    tool: &self.pr.robots[k].tool,
                    from: &from[k],
                    to: &to[k],
                };
                if motions_collide::<M, D>(&a, &b, self.p.low.motion_step) {
                    return false;
                }
            }
        }
        true
    }

    fn write(&self, mut id: u32, out: &mut Solution<'_, D>) {
        let last = &self.nodes[id as usize];
        for r in 0..self.n {
            out.assignment[r] = (last.assign[r] != u8::MAX).then_some(last.assign[r]);
        }
        loop {
            let node = &self.nodes[id as usize];
            for r in 0..self.n {
                out.paths[r * self.h + node.t as usize] = node.q[r];
            }
            if node.parent == u32::MAX {
                return;
            }
            id = node.parent;
        }
    }
}

/// Mixed-radix counter over `counts`; `false` after the last combination.
fn next_digits(d: &mut [usize], counts: &[usize]) -> bool {
    for i in 0..d.len() {
        d[i] += 1;
        if d[i] < counts[i] {
            return true;
        }
        d[i] = 0;
    }
    false
}
