//! Fitting a few capsules that enclose a point cloud.
//!
//! For a given axis line and radius the smallest enclosing capsule is closed-form: the radius
//! must reach the point farthest from the line, and each end of the segment is trimmed as far
//! as the rounded caps still cover every point ([`enclose`]). What remains is choosing the line
//! (and possibly a radius above the minimum, which shortens the segment): a Nelder-Mead search
//! over the line's tilt and offset from each principal axis, minimising volume. Several
//! capsules come from splitting the cloud, one group in two at a time along the group's
//! principal axes ([`refine`]); the caller keeps the splits that bring the capsules closest to
//! the mesh ([`Fit::score`]), since least volume leaves a capsule far off a thin part.

use std::f64::consts::PI;

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

use super::minimize::nelder_mead;
use super::shape::Capsule;
use super::slack::{MeshDistance, Slack};

type V3 = Vector3<f64>;

/// The smallest capsule around `points` whose axis is the line through `origin` along the unit
/// vector `dir`, with radius `extra` above the minimum.
pub fn enclose(points: &[V3], origin: &V3, dir: &V3, extra: f64) -> Capsule {
    // Axial coordinate and squared distance from the line of each point. Written out per
    // component: this is the fitter's inner loop, and it stays fast in unoptimised builds.
    let (o, d) = ([origin.x, origin.y, origin.z], [dir.x, dir.y, dir.z]);
    let coords = points.iter().map(|p| {
        let v = [p.x - o[0], p.y - o[1], p.z - o[2]];
        let t = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
        (
            t,
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] - t * t).max(0.0),
        )
    });
    let radius = coords
        .clone()
        .fold(0.0, |m: f64, (_, rho2)| m.max(rho2))
        .sqrt()
        + extra;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (t, rho2) in coords {
        // The caps reach this far beyond the segment at this point's distance from the line.
        let reach = (radius * radius - rho2).max(0.0).sqrt();
        hi = hi.max(t - reach);
        lo = lo.min(t + reach);
    }
    if lo > hi {
        // A sphere centred anywhere in [hi, lo] holds every point.
        let mid = 0.5 * (lo + hi);
        (lo, hi) = (mid, mid);
    }
    Capsule {
        a: origin + dir * lo,
        b: origin + dir * hi,
        radius,
    }
}

/// Centroid and principal axes (largest spread first) of `points`, as a right-handed frame
/// with each axis's largest component positive, so the result does not depend on the
/// eigen-solver's sign choices.
fn principal_axes(points: &[V3]) -> (V3, [V3; 3]) {
    let n = points.len().max(1) as f64;
    let centroid = points.iter().sum::<V3>() / n;
    let cov = points.iter().fold(Matrix3::zeros(), |acc, p| {
        let d = p - centroid;
        acc + d * d.transpose()
    }) / n;
    let eigen = SymmetricEigen::new(cov);
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| eigen.eigenvalues[j].total_cmp(&eigen.eigenvalues[i]));
    let axis = |i: usize| {
        let v: V3 = eigen.eigenvectors.column(order[i]).into();
        let largest = v.iamax();
        if v[largest] < 0.0 {
            -v
        } else {
            v
        }
    };
    let (e0, e1) = (axis(0), axis(1));
    (centroid, [e0, e1, e0.cross(&e1)])
}

/// Points extreme in one of a fixed set of directions: vertices of the convex hull, a few
/// hundred at most. A capsule is convex, so it holds a set when it holds the set's hull; the
/// search works on these and the result is checked against all points.
fn support_points(points: &[V3]) -> Vec<V3> {
    const DIRECTIONS: usize = 200;
    let golden = PI * (3.0 - 5f64.sqrt());
    let mut chosen: Vec<usize> = (0..DIRECTIONS)
        .filter_map(|k| {
            // Fibonacci sphere: near-uniform directions.
            let z = 1.0 - (2.0 * k as f64 + 1.0) / DIRECTIONS as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * k as f64;
            let dir = V3::new(r * phi.cos(), r * phi.sin(), z);
            let height = |p: &V3| p.x * dir.x + p.y * dir.y + p.z * dir.z;
            (0..points.len()).max_by(|&i, &j| height(&points[i]).total_cmp(&height(&points[j])))
        })
        .collect();
    chosen.sort_unstable();
    chosen.dedup();
    chosen.into_iter().map(|i| points[i]).collect()
}

/// The best single capsule around `points`.
fn fit_one(points: &[V3]) -> Capsule {
    let (centroid, axes) = principal_axes(points);
    let scale = points
        .iter()
        .map(|p| (p - centroid).norm())
        .fold(0.0, f64::max);
    if scale == 0.0 {
        return Capsule {
            a: centroid,
            b: centroid,
            radius: 0.0,
        };
    }
    let hull_sample = support_points(points);
    let mut best: Option<Capsule> = None;
    for i in 0..3 {
        let (e0, e1, e2) = (axes[i], axes[(i + 1) % 3], axes[(i + 2) % 3]);
        // Parameters: line offset (2, in units of `scale`), tilt (2), extra radius (1).
        let line = |x: &[f64; 5]| {
            let origin = centroid + (e1 * x[0] + e2 * x[1]) * scale;
            let dir = (e0 + e1 * x[2] + e2 * x[3]).normalize();
            (origin, dir, x[4].abs() * scale)
        };
        let mut support = hull_sample.clone();
        let mut x = [0.0; 5];
        // Search on the hull sample; if the capsule misses points outside the sample, add them
        // and search again (a few rounds at most: few points ever stick out).
        for _ in 0..4 {
            let volume = |x: &[f64; 5]| {
                let (origin, dir, extra) = line(x);
                enclose(&support, &origin, &dir, extra).volume()
            };
            for _ in 0..2 {
                // A restart from the optimum escapes a collapsed simplex.
                x = nelder_mead(volume, x, [0.05, 0.05, 0.1, 0.1, 0.02], 800).0;
            }
            let (origin, dir, extra) = line(&x);
            let on_support = enclose(&support, &origin, &dir, extra);
            let missed: Vec<V3> = points
                .iter()
                .filter(|p| !on_support.contains(p))
                .copied()
                .collect();
            if missed.is_empty() {
                break;
            }
            support.extend(missed);
        }
        let (origin, dir, extra) = line(&x);
        let capsule = enclose(points, &origin, &dir, extra);
        if best.is_none_or(|b| capsule.volume() < b.volume()) {
            best = Some(capsule);
        }
    }
    best.expect("three axes were tried")
}

/// Capsules around groups of points that together are the whole cloud, and their slack.
#[derive(Clone, Debug)]
pub struct Fit {
    pub capsules: Vec<Capsule>,
    groups: Vec<Vec<V3>>,
    pub slack: Slack,
}

impl Fit {
    /// One capsule around all of `points`.
    pub fn one(points: &[V3], mesh: &MeshDistance) -> Fit {
        Fit::new(vec![points.to_vec()], vec![fit_one(points)], mesh)
    }

    fn new(groups: Vec<Vec<V3>>, capsules: Vec<Capsule>, mesh: &MeshDistance) -> Fit {
        Fit {
            slack: mesh.slack(&capsules),
            capsules,
            groups,
        }
    }

    /// What the fitter minimises: the largest slack plus the mean.
    pub fn score(&self) -> f64 {
        self.slack.largest + self.slack.mean
    }
}

/// Every way of splitting one group of `fit` in two along one of the group's principal axes,
/// cut at eighths of its points; none when no group has enough points.
pub fn refine(fit: &Fit, mesh: &MeshDistance) -> Vec<Fit> {
    const CUTS: usize = 8;
    let mut candidates: Vec<Fit> = Vec::new();
    for (i, group) in fit.groups.iter().enumerate() {
        if group.len() < 2 * CUTS {
            continue;
        }
        let (centroid, axes) = principal_axes(group);
        for axis in &axes {
            let mut sorted = group.clone();
            let height = |p: &V3| (p - centroid).dot(axis);
            sorted.sort_by(|p, q| height(p).total_cmp(&height(q)));
            for cut in 1..CUTS {
                let at = cut * sorted.len() / CUTS;
                let (low, high) = (sorted[..at].to_vec(), sorted[at..].to_vec());
                // The other groups keep their capsules.
                let mut capsules = fit.capsules.clone();
                capsules[i] = fit_one(&low);
                capsules.push(fit_one(&high));
                let mut groups = fit.groups.clone();
                groups[i] = low;
                groups.push(high);
                candidates.push(Fit::new(groups, capsules, mesh));
            }
        }
    }
    candidates
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::Mesh;

    /// A closed cylinder mesh (rings, end caps fanned to their centres) around the line through
    /// `origin` along `dir`.
    fn cylinder(origin: V3, dir: V3, radius: f64, length: f64) -> Mesh {
        const RINGS: usize = 20;
        const AROUND: usize = 36;
        let dir = dir.normalize();
        let u = dir.cross(&V3::new(0.3, 0.5, 0.8)).normalize();
        let v = dir.cross(&u);
        let mut mesh = Mesh::default();
        for i in 0..=RINGS {
            let t = length * i as f64 / RINGS as f64;
            for k in 0..AROUND {
                let a = 2.0 * PI * k as f64 / AROUND as f64;
                mesh.vertices
                    .push(origin + dir * t + (u * a.cos() + v * a.sin()) * radius);
                let (next, up) = ((k + 1) % AROUND, AROUND);
                let here = i * AROUND;
                if i < RINGS {
                    mesh.triangles.push([here + k, here + next, here + up + k]);
                    mesh.triangles
                        .push([here + next, here + up + next, here + up + k]);
                }
            }
        }
        for (ring, centre) in [(0, origin), (RINGS, origin + dir * length)] {
            let c = mesh.vertices.len();
            mesh.vertices.push(centre);
            for k in 0..AROUND {
                let at = ring * AROUND;
                mesh.triangles.push([c, at + k, at + (k + 1) % AROUND]);
            }
        }
        mesh
    }

    /// The best of `fit`'s splits.
    fn best_split(fit: &Fit, mesh: &MeshDistance) -> Fit {
        refine(fit, mesh)
            .into_iter()
            .reduce(|b, f| if f.score() < b.score() { f } else { b })
            .expect("enough points to split")
    }

    fn assert_encloses(capsules: &[Capsule], points: &[V3]) {
        for p in points {
            let gap = capsules
                .iter()
                .map(|c| c.axis_distance(p) - c.radius)
                .fold(f64::INFINITY, f64::min);
            assert!(gap <= 1e-9, "point {p:?} is {gap} m outside {capsules:?}");
        }
    }

    #[test]
    fn enclose_trims_the_ends_to_the_caps() {
        // Two points on the axis and one on the rim: radius 1, ends trimmed to the rim point.
        let points = [
            V3::new(0.0, 0.0, 0.0),
            V3::new(0.0, 0.0, 5.0),
            V3::new(1.0, 0.0, 2.0),
        ];
        let c = enclose(&points, &V3::zeros(), &V3::z(), 0.0);
        assert!((c.radius - 1.0).abs() < 1e-12);
        assert!((c.a - V3::new(0.0, 0.0, 1.0)).norm() < 1e-12, "{c:?}");
        assert!((c.b - V3::new(0.0, 0.0, 4.0)).norm() < 1e-12, "{c:?}");
    }

    #[test]
    fn enclose_collapses_to_a_sphere_for_a_compact_cloud() {
        let points = [
            V3::new(0.0, 0.0, -0.1),
            V3::new(0.0, 0.0, 0.1),
            V3::new(0.0, 0.5, 0.0),
        ];
        let c = enclose(&points, &V3::zeros(), &V3::z(), 0.0);
        assert_eq!(c.a, c.b);
        assert_encloses(&[c], &points);
    }

    #[test]
    fn one_capsule_fits_a_tilted_cylinder_tightly() {
        let (radius, length) = (0.05, 0.3);
        let mesh = cylinder(
            V3::new(0.1, -0.2, 0.3),
            V3::new(1.0, 2.0, -0.5),
            radius,
            length,
        );
        let capsule = fit_one(&mesh.vertices);
        assert_encloses(&[capsule], &mesh.vertices);
        // A radius a little above the cylinder's lets the caps cover the flat ends with a
        // shorter segment, which saves volume; never much above it.
        assert!(
            capsule.radius >= radius - 1e-9 && capsule.radius < 1.02 * radius,
            "{capsule:?}"
        );
        // At most the capsule on the cylinder's own axis and radius.
        let on_axis = Capsule {
            a: V3::zeros(),
            b: V3::x() * length,
            radius,
        };
        assert!(capsule.volume() <= on_axis.volume(), "{capsule:?}");
    }

    #[test]
    fn an_l_shape_split_in_two_stands_closer_to_its_mesh() {
        let mut mesh = cylinder(V3::zeros(), V3::z(), 0.04, 0.4);
        mesh.append(cylinder(V3::new(0.0, 0.0, 0.4), V3::x(), 0.04, 0.4));
        let distance = MeshDistance::new(&mesh).expect("triangles");
        let one = Fit::one(&mesh.vertices, &distance);
        let two = best_split(&one, &distance);
        assert_encloses(&two.capsules, &mesh.vertices);
        assert_eq!(two.capsules.len(), 2);
        // One capsule around the L stands off it by half the L's size somewhere; two, one per
        // bar, by little more than a cap over a flat end.
        assert!(one.slack.largest > 0.1, "{:?}", one.slack);
        assert!(two.slack.largest < 0.05, "{:?}", two.slack);
        assert!(
            two.slack.mean < 0.5 * one.slack.mean,
            "{:?} {:?}",
            two.slack,
            one.slack
        );
        for c in &two.capsules {
            assert!(c.radius < 0.045, "{:?}", two.capsules);
        }
    }

    #[test]
    fn fitting_is_deterministic() {
        let mut mesh = cylinder(V3::zeros(), V3::new(0.2, 0.1, 1.0), 0.03, 0.2);
        mesh.append(cylinder(V3::new(0.05, 0.0, 0.2), V3::y(), 0.05, 0.1));
        let distance = MeshDistance::new(&mesh).expect("triangles");
        let split = || best_split(&Fit::one(&mesh.vertices, &distance), &distance).capsules;
        assert_eq!(split(), split());
    }
}
