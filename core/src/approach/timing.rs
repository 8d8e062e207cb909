//! Time parametrisation of an approach: the arms go from waypoint to waypoint (composite
//! configurations) along straight joint-space segments, each with a cosine time profile that
//! starts and ends at rest, sampled every `dt`. Rest at every waypoint keeps the acceleration
//! bounded without blending; each segment gets just enough samples for the velocity and
//! acceleration limits. A sample lies on its segment, so the motion between two samples is a
//! piece of the checked composite motion.

use core::f64::consts::PI;

use crate::model::Models;

use super::query::{ApproachError, ApproachParams};

/// Samples (`dt` apart) the composite segment `a -> b` needs under the cosine profile: its
/// largest step is `pi / 2N` of the distance and its largest second difference
/// `(pi / N)^2 / 2` of it. 0 when nothing moves.
pub(super) fn samples<M: Models<D>, const D: usize>(
    models: &[u8],
    a: &[[f64; D]],
    b: &[[f64; D]],
    dt: f64,
    params: &ApproachParams,
) -> usize {
    let mut need = 0.0f64;
    for ((qa, qb), &model) in a.iter().zip(b).zip(models) {
        let (velocity, acceleration) = (M::velocity(model), M::acceleration(model));
        for j in 0..D {
            let d = libm::fabs(qb[j] - qa[j]);
            need = need.max(PI * d / (2.0 * params.speed * velocity[j] * dt));
            if params.acceleration > 0.0 {
                let limit = params.acceleration * acceleration[j];
                need = need.max(PI * libm::sqrt(d / (2.0 * limit)) / dt);
            }
        }
    }
    libm::ceil(need) as usize
}

/// Writes the parametrised motion through `waypoints` (`m` composite configurations of `n`
/// robots, `waypoints[k * n + i]`), the first excluded and the last excluded too (it is the
/// path's first configuration, which follows): robot `i`'s approach goes to
/// `out[i * cap..i * cap + A]`. Returns `A`.
pub(super) fn write<M: Models<D>, const D: usize>(
    models: &[u8],
    waypoints: &[[f64; D]],
    n: usize,
    dt: f64,
    params: &ApproachParams,
    out: &mut [[f64; D]],
) -> Result<usize, ApproachError> {
    let cap = out.len() / n.max(1);
    let m = waypoints.len() / n.max(1);
    let segment = |k: usize| {
        (
            &waypoints[k * n..(k + 1) * n],
            &waypoints[(k + 1) * n..(k + 2) * n],
        )
    };
    let counts = || {
        (0..m.saturating_sub(1)).map(|k| {
            let (a, b) = segment(k);
            samples::<M, D>(models, a, b, dt, params)
        })
    };
    let total: usize = counts().sum();
    let len = total.saturating_sub(1);
    if len > cap {
        return Err(ApproachError::TooLong {
            needed: len,
            capacity: cap,
        });
    }
    let mut written = 0;
    for (k, count) in counts().enumerate() {
        let (a, b) = segment(k);
        for s in 1..=count {
            if written == len {
                break;
            }
            let f = 0.5 * (1.0 - libm::cos(PI * s as f64 / count as f64));
            for i in 0..n {
                out[i * cap + written] = if s == count {
                    b[i]
                } else {
                    core::array::from_fn(|j| a[i][j] + f * (b[i][j] - a[i][j]))
                };
            }
            written += 1;
        }
    }
    Ok(len)
}
