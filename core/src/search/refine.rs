//! Refinement levels: when a planner exhausts its search space at one resolution it goes on at
//! a finer one, until the deadline or the finest level is exhausted too.
//!
//! Level 0 is the caller's [`OmegaParams`]; every later level draws more start states from
//! more IK seeds (the first seeds are the same, so their IK answers are reused from the
//! [`super::StartCache`]), detects duplicates on a finer grid and checks motions with a finer
//! sweep (links inflated by 2.5 mm, then 1.25 mm, instead of 5 mm), and the last one also
//! takes smaller null-space steps. The schedule counts levels, not time, so it is
//! deterministic. The numbers come from the problems level 0 missed: 64 start states from up
//! to 2,000 seeds and a grid of 0.05 rad solved the ones measured; the levels
//! between reach the easier ones sooner. The finer sweeps come from the refinement family
//! (`omcbsa gen-bench --refine`), whose fixtures stand 2 to 5 cm from the witness: there the
//! 5 mm inflation turns passes a few millimetres apart into conflicts that no branching
//! removes. Level 0 keeps the coarse sweep, which is a quarter cheaper on the suite.
//!
//! ```
//! use omcbsa_core::search::refine::{level_params, LEVELS};
//! use omcbsa_core::search::OmegaParams;
//!
//! let base = OmegaParams::default();
//! assert_eq!(level_params(&base, 0), base);
//! let finest = level_params(&base, LEVELS - 1);
//! assert!(finest.resolution < base.resolution && finest.start_attempts > base.start_attempts);
//! // Past the last level: the last.
//! assert_eq!(level_params(&base, LEVELS + 3), finest);
//! ```

use super::params::OmegaParams;

/// The reason planners report when every level was exhausted.
pub const EXHAUSTED: &str = "every refinement level was searched without a plan";

/// The reason when the levels a caller allowed (fewer than [`LEVELS`]) were all searched
/// without a plan: no proof that there is none.
pub const LEVEL_CAP: &str = "the refinement levels allowed were searched without a plan";

/// Levels in all, level 0 included.
pub const LEVELS: u8 = 4;

/// (start states, IK seeds, duplicate grid in rad, null-space step, motion step in m) of
/// levels 1.. .
const FINER: [(usize, u32, f64, f64, f64); LEVELS as usize - 1] = [
    (64, 500, 0.3, 0.2, 0.0025),
    (64, 2000, 0.1, 0.2, 0.0025),
    (128, 4000, 0.05, 0.1, 0.0025),
];

/// The round of Ω-CBSA's restarts in which each level builds its first constraint tree; from
/// then on its trees double round by round, as level 0's do. Level 1 answers most of what
/// level 0 misses (66 of the 72 refinement-family problems solved in one run), and its trees
/// need more expansions than level 0's (each search has four times the start states and a
/// finer grid), so it starts one round behind level 0, with half its share. Levels 2 and 3
/// are rarely needed and a single search of theirs can take 10^5 expansions, so they start
/// late (a sixteenth and a sixty-fourth of level 0's share). Measured: with level 1 from round
/// 2 (a quarter of the share) the refinement family lost two problems to the 5 s limit; with
/// every level `l` from round `l` (and roots counted in the budgets), three others.
pub const FIRST_ROUND: [u32; LEVELS as usize] = [0, 1, 4, 6];

/// The Ω-A* settings of `level` (0: `base` itself). A level past the last is the last.
pub fn level_params(base: &OmegaParams, level: u8) -> OmegaParams {
    if level == 0 {
        return *base;
    }
    let (solutions, attempts, resolution, epsilon, motion_step) =
        FINER[(usize::from(level) - 1).min(FINER.len() - 1)];
    // Never coarser than the caller asked for.
    OmegaParams {
        start_solutions: solutions.max(base.start_solutions),
        start_attempts: attempts.max(base.start_attempts),
        resolution: resolution.min(base.resolution),
        epsilon: epsilon.min(base.epsilon),
        motion_step: motion_step.min(base.motion_step),
        ..*base
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_get_finer_and_level_zero_is_the_callers() {
        let base = OmegaParams::default();
        assert_eq!(level_params(&base, 0), base);
        for l in 1..LEVELS {
            let (a, b) = (level_params(&base, l - 1), level_params(&base, l));
            assert!(b.start_attempts >= a.start_attempts && b.start_solutions >= a.start_solutions);
            assert!(b.resolution < a.resolution && b.epsilon <= a.epsilon);
            assert!(b.motion_step <= a.motion_step);
        }
        assert_eq!(level_params(&base, LEVELS), level_params(&base, LEVELS - 1));
    }
}
