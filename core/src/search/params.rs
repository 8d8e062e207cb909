//! Ω-A*'s tunables, and how they follow the step length: a leaf the search, the refinement
//! levels and the planners above read.

use crate::ik::IkParams;

/// Tunables of Ω-A*. The defaults are the paper's (`ε = 0.2`, `w_h = 10`, `w_c = 0.1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OmegaParams {
    /// Null-space step, rad (along a unit null-space direction).
    pub epsilon: f64,
    /// Weight of the heuristic (steps left).
    pub w_h: f64,
    /// Weight of the collision count.
    pub w_c: f64,
    /// Weight of the cost of coming near two collinear joint axes: each step adds `w_a`
    /// times how far [`axis_separation`](crate::kinematics::axis_separation) is below
    /// `axis_margin`. 0 (the paper's) leaves it out; online planning, which cannot see the
    /// hand's motion beyond a chunk, uses it so that the null space keeps the arm away from
    /// configurations it could not leave fast enough.
    pub w_a: f64,
    /// Separation (see [`axis_separation`](crate::kinematics::axis_separation)) below which
    /// `w_a` counts.
    pub axis_margin: f64,
    /// Weight of the cost of the joints' speed headroom: each step adds `w_v` times how far
    /// [`speed_ratio`](crate::kinematics::speed_ratio) of the hand's motion at that step (the
    /// last step's motion continued past the trajectory's end) is above `speed_margin`. 0
    /// (the paper's) leaves it out; online planning, which cannot see past a chunk, uses it
    /// so that the arm takes configurations from which the hand's motion can go on faster.
    pub w_v: f64,
    /// Share of the joints' speed limits above which `w_v` and `w_r` count.
    pub speed_margin: f64,
    /// Weight of the joints' reserve for a motion the search cannot see: each step costs
    /// `w_r` times how far [`speed_ratio`] of each of six reference twists (translating
    /// along, and turning about, each of the tool's axes at `reserve_speed`) is above
    /// `speed_margin`, summed. 0 (the paper's) leaves it out; online planning uses it so that
    /// where the hands wait or move slowly, the arm turns in its null space to where it can
    /// follow whatever motion comes next (a wrist turn needs two wrist joints sharing it).
    ///
    /// [`speed_ratio`]: crate::kinematics::speed_ratio
    pub w_r: f64,
    /// Whether a robot that starts free (not where it stands) starts where its joints'
    /// reserve is largest rather than at the first pose's IK answer nearest `initial`
    /// ([`crate::tracking::ranked_starts`]; counts only with `w_r`). Online planning sets it
    /// for a first chunk long enough to let the chunks after it see the hands' fast motions
    /// coming.
    pub rank_starts: bool,
    /// The reference twists' speeds: metres per second along, radians per second about, each
    /// of the tool's axes.
    pub reserve_speed: (f64, f64),
    /// Most valid IK solutions of the first pose put in OPEN per trajectory.
    pub start_solutions: usize,
    /// Most random IK seeds tried per trajectory to find them.
    pub start_attempts: u32,
    /// Grid size (rad) of the duplicate detection on `q`: two states of one step and
    /// trajectory in the same cell are one state. The paper leaves it open; on the benchmark
    /// suite 0.6 rad (three null-space steps) kept Ω-CBSA's success rate and cut its mean time
    /// 3x against 0.1 rad, whose finer lattice makes the searches that must fail (children
    /// with no path under their constraints) far longer; 0.8 began to lose problems.
    pub resolution: f64,
    /// Largest displacement (m) of any point of the arm between two checked configurations
    /// of a motion; the checks inflate the links by half of it, so they are conservative.
    pub motion_step: f64,
    /// The IK projection's settings.
    pub ik: IkParams,
    /// Seed of the random IK seeds.
    pub seed: u64,
}

/// The step (s) the null-space step and the duplicate grid are tuned for: the benchmark
/// suite's.
pub const REFERENCE_DT: f64 = 0.2;

impl OmegaParams {
    /// These settings for steps of `dt` s. Below [`REFERENCE_DT`], the null-space step and the
    /// duplicate grid shrink in proportion, so that the search moves along the null space at
    /// the same speed (rad/s) whatever the rate: at 50 Hz, 0.2 rad would be seven times what a
    /// Gen3 joint may move in a step, every null-space move would break the velocity limit,
    /// and only the IK projection would be left (IK tracking). Longer steps keep the settings.
    pub fn at_step(&self, dt: f64) -> OmegaParams {
        let s = dt / REFERENCE_DT;
        // Negated so that NaN keeps the settings (the planners refuse such a dt anyway).
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(s > 0.0 && s < 1.0) {
            return *self;
        }
        OmegaParams {
            epsilon: self.epsilon * s,
            resolution: self.resolution * s,
            ..*self
        }
    }
}

impl Default for OmegaParams {
    fn default() -> Self {
        OmegaParams {
            epsilon: 0.2,
            w_h: 10.0,
            w_c: 0.1,
            w_a: 0.0,
            axis_margin: 0.5,
            w_v: 0.0,
            speed_margin: 0.5,
            w_r: 0.0,
            reserve_speed: (0.5, 2.0),
            rank_starts: false,
            start_solutions: 16,
            start_attempts: 96,
            resolution: 0.6,
            motion_step: crate::motion::MOTION_STEP,
            ik: IkParams::default(),
            seed: 0x5eed,
        }
    }
}
