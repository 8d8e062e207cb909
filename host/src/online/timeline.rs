//! The arms' timeline as the [`super::Embodier`] keeps it: every robot's configuration at each
//! timeline index (`dt` apart) from the last one sent on, and what each index tracks: a policy
//! pose, a point between two consecutive poses (a time-scaled chunk spreads its poses over
//! more indices), or nothing (where the arms stand, the approach, a hold).
//!
//! Unscaled, policy step `s` sits at index `offset + s`; time scaling and holds shift the
//! steps after them, so the map from steps to indices is read off the targets kept.

use omcbsa_core::model::Frame;

use crate::models::DOF;

/// What the hands track at one timeline index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// Nothing: `initial`, the approach, a hold. The hand goes where the arm takes it.
    Free,
    /// The policy's pose at step `step` (`frac == 0`), or `frac` of the way from it to the
    /// pose at `step + 1` (a time-scaled chunk's inserted index).
    Pose {
        /// The policy step at or before this index.
        step: u64,
        /// How far towards the next step, in `[0, 1)`.
        frac: f64,
    },
}

impl Target {
    /// The policy step this index reaches exactly, if any.
    pub fn exact_step(self) -> Option<u64> {
        match self {
            Target::Pose { step, frac: 0.0 } => Some(step),
            _ => None,
        }
    }
}

/// Every robot's configurations and the targets, from index `start` on.
#[derive(Clone, Debug, Default)]
pub(super) struct Timeline {
    /// Per robot, its configuration at indices `start..`.
    paths: Vec<Vec<[f64; DOF]>>,
    /// The target of each index `start..` (as long as every path).
    targets: Vec<Target>,
    start: usize,
    /// The last exact (index, step) forgotten, to place steps before `start`.
    before: Option<(usize, u64)>,
}

impl Timeline {
    /// A timeline of `robots` paths starting at index 0, the arms where `initial` puts them.
    pub fn new(initial: &[[f64; DOF]]) -> Timeline {
        Timeline {
            paths: initial.iter().map(|q| vec![*q]).collect(),
            targets: vec![Target::Free],
            start: 0,
            before: None,
        }
    }

    /// Index one past the last configuration kept.
    pub fn end(&self) -> usize {
        self.start + self.targets.len()
    }

    /// The first index kept.
    pub fn start(&self) -> usize {
        self.start
    }

    /// Robot `robot`'s configuration at `index`, if still kept; past the end, the last one
    /// (the arm holds there).
    pub fn configuration(&self, robot: usize, index: usize) -> Option<[f64; DOF]> {
        let path = self.paths.get(robot)?;
        let k = index.checked_sub(self.start)?;
        path.get(k.min(path.len().checked_sub(1)?)).copied()
    }

    /// Robot `robot`'s configurations from `from` to the end.
    pub fn planned(&self, robot: usize, from: usize) -> &[[f64; DOF]] {
        let path = self.paths.get(robot).map_or(&[][..], Vec::as_slice);
        let k = from.saturating_sub(self.start).min(path.len());
        &path[k..]
    }

    /// What index `index` tracks (`Free` past the end: a hold).
    pub fn target(&self, index: usize) -> Target {
        index
            .checked_sub(self.start)
            .and_then(|k| self.targets.get(k))
            .copied()
            .unwrap_or(Target::Free)
    }

    /// The index where policy step `step` is (or will be) reached: where it is kept; past the
    /// last step kept, as many indices after it as steps; before what is kept, counted from
    /// the last step forgotten. `None` before any step was placed.
    pub fn index_of(&self, step: u64) -> Option<usize> {
        let mut later = None;
        for (k, t) in self.targets.iter().enumerate().rev() {
            if let Target::Pose { step: s, frac } = *t {
                if s < step || (s == step && frac == 0.0) {
                    return Some(self.start + k + (step - s) as usize);
                }
                later = Some((self.start + k, s));
            }
        }
        match (self.before, later) {
            (Some((i, s)), _) if s <= step => Some(i + (step - s) as usize),
            // A step before every one kept: as many indices before the first kept.
            (_, Some((i, s))) => i.checked_sub((s - step) as usize),
            (Some((i, s)), None) => i.checked_sub((s - step) as usize),
            (None, None) => None,
        }
    }

    /// Replaces everything from `index` on (at least one index kept before it: where the
    /// arms come from) with `paths` (per robot) and `targets`; a gap between the end and
    /// `index` is filled with the last configuration (a hold).
    pub fn replace_from(&mut self, index: usize, paths: &[&[[f64; DOF]]], targets: &[Target]) {
        let keep = index.saturating_sub(self.start).max(1);
        for (w, path) in self.paths.iter_mut().zip(paths) {
            let last = *w.last().unwrap_or(&path[0]);
            w.resize(keep.min(w.len()), last);
            w.resize(keep, last);
            w.extend_from_slice(path);
        }
        self.targets.truncate(keep);
        self.targets.resize(keep, Target::Free);
        self.targets.extend_from_slice(targets);
    }

    /// Drops everything from `index` on (at least the first index kept stays): the arms hold
    /// at the last configuration left.
    pub fn truncate(&mut self, index: usize) {
        let keep = index.saturating_sub(self.start).max(1);
        self.paths.iter_mut().for_each(|p| p.truncate(keep));
        self.targets.truncate(keep);
    }

    /// Forgets every index before `index` but the one before it (where a plan from `index`
    /// starts), and never the last one kept.
    pub fn forget_before(&mut self, index: usize) {
        let keep_from = index.saturating_sub(1).min(self.end().saturating_sub(1));
        let drop = keep_from.saturating_sub(self.start);
        if drop == 0 {
            return;
        }
        for (k, t) in self.targets[..drop].iter().enumerate() {
            if let Some(step) = t.exact_step() {
                self.before = Some((self.start + k, step));
            }
        }
        self.paths.iter_mut().for_each(|p| {
            p.drain(..drop);
        });
        self.targets.drain(..drop);
        self.start += drop;
    }
}

/// The pose `frac` of the way from `a` to `b`: position along the segment, rotation along
/// the shortest arc (the path a hand between two consecutive policy poses is taken to follow).
pub fn between(a: &Frame, b: &Frame, frac: f64) -> Frame {
    use omcbsa_core::nalgebra::{Rotation3, UnitQuaternion};
    if frac == 0.0 {
        return *a;
    }
    let qa = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(a.rot));
    let qb = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(b.rot));
    let rot = qa
        .try_slerp(&qb, frac, 1e-9)
        .unwrap_or(qa)
        .to_rotation_matrix()
        .into_inner();
    Frame {
        rot,
        pos: a.pos + (b.pos - a.pos) * frac,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(step: u64) -> Target {
        Target::Pose { step, frac: 0.0 }
    }

    #[test]
    fn steps_map_to_indices_through_scaled_chunks_and_holds() {
        let mut t = Timeline::new(&[[0.0; DOF]]);
        // Index 0 initial, 1-2 approach, then steps 10, 10.5, 11, 12.
        let q = [[1.0; DOF]; 6];
        let targets = [
            Target::Free,
            Target::Free,
            pose(10),
            Target::Pose {
                step: 10,
                frac: 0.5,
            },
            pose(11),
            pose(12),
        ];
        t.replace_from(1, &[&q], &targets);
        assert_eq!(t.end(), 7);
        assert_eq!(t.index_of(10), Some(3));
        assert_eq!(t.index_of(11), Some(5));
        assert_eq!(t.index_of(12), Some(6));
        // Past the end: one index a step.
        assert_eq!(t.index_of(15), Some(9));
        assert_eq!(t.index_of(9), Some(2));
        t.forget_before(6);
        assert_eq!(t.start(), 5);
        assert_eq!(t.index_of(11), Some(5));
        // Forgotten steps are counted from the last exact one forgotten.
        assert_eq!(t.index_of(10), Some(3));
        assert_eq!(t.configuration(0, 100), Some([1.0; DOF]));
    }

    #[test]
    fn between_interpolates_position_and_rotation() {
        let a = Frame::IDENTITY;
        let mut b = Frame::IDENTITY;
        b.pos.x = 2.0;
        b.rot = omcbsa_core::nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 1.0).into_inner();
        let m = between(&a, &b, 0.5);
        assert!((m.pos.x - 1.0).abs() < 1e-12);
        let angle = omcbsa_core::nalgebra::Rotation3::from_matrix_unchecked(m.rot).angle();
        assert!((angle - 0.5).abs() < 1e-12);
    }
}
