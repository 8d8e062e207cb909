//! Rust source for one model: constants and the unrolled `fk`, `link_frames` and `jacobian`.
//!
//! All three walk the chain with the same [`step`]: `child = parent * origin * motion(q)`, with
//! `origin` a literal transform computed here. `fk` and `jacobian` walk a folded chain in which
//! each run of fixed joints is merged into the next joint's origin (or into one trailing tool
//! transform); `link_frames` walks every joint so it can report every link.

use std::fmt::Write;

use crate::chain::{Chain, Motion};
use crate::collision::Geometry;
use crate::sym::{lit, Emitter, Sym};
use crate::transform::{Transform, Vec3};

#[derive(Clone, Copy)]
struct Step {
    origin: Transform,
    motion: Motion,
    /// Index of the joint variable in `q` (actuated joints only).
    var: Option<usize>,
}

/// One step per joint, in chain order.
fn all_steps(chain: &Chain) -> Vec<Step> {
    let mut var = 0;
    chain
        .joints
        .iter()
        .map(|j| {
            let step = Step {
                origin: j.origin,
                motion: j.motion,
                var: (j.motion != Motion::Fixed).then_some(var),
            };
            var += usize::from(step.var.is_some());
            step
        })
        .collect()
}

/// One step per actuated joint with preceding fixed joints folded into its origin, plus one
/// fixed step for the fixed joints after the last actuated joint (if any).
fn folded_steps(chain: &Chain) -> Vec<Step> {
    let mut steps = Vec::new();
    let mut pending: Option<Transform> = None;
    for step in all_steps(chain) {
        let origin = pending
            .take()
            .map_or(step.origin, |p| p.compose(&step.origin));
        if step.var.is_some() {
            steps.push(Step { origin, ..step });
        } else {
            pending = Some(origin);
        }
    }
    steps.extend(pending.map(|origin| Step {
        origin,
        motion: Motion::Fixed,
        var: None,
    }));
    steps
}

#[derive(Clone)]
struct SymFrame {
    rot: [[Sym; 3]; 3],
    pos: [Sym; 3],
}

impl SymFrame {
    fn identity() -> SymFrame {
        let rot = std::array::from_fn(|i| std::array::from_fn(|j| Sym::Lit(f64::from(i == j))));
        SymFrame {
            rot,
            pos: std::array::from_fn(|_| Sym::ZERO),
        }
    }

    fn code(&self) -> String {
        let rot: Vec<String> = self.rot.iter().flatten().map(Sym::code).collect();
        let pos: Vec<String> = self.pos.iter().map(Sym::code).collect();
        format!(
            "crate::model::Frame {{ rot: ::nalgebra::Matrix3::new({}), pos: ::nalgebra::Vector3::new({}) }}",
            rot.join(", "),
            pos.join(", ")
        )
    }
}

/// `frame.rot * v`, each component bound to `{name}{i}`.
fn rotate(e: &mut Emitter, name: &str, frame: &SymFrame, v: &[Sym; 3]) -> [Sym; 3] {
    std::array::from_fn(|i| {
        let terms: Vec<(&Sym, &Sym)> = (0..3).map(|k| (&frame.rot[i][k], &v[k])).collect();
        e.sum_of_products(&format!("{name}{i}"), &terms)
    })
}

/// `a.rot * b`, entries bound to `{name}{i}{j}`.
fn rot_product(e: &mut Emitter, name: &str, a: &SymFrame, b: &[[Sym; 3]; 3]) -> [[Sym; 3]; 3] {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let terms: Vec<(&Sym, &Sym)> = (0..3).map(|k| (&a.rot[i][k], &b[k][j])).collect();
            e.sum_of_products(&format!("{name}{i}{j}"), &terms)
        })
    })
}

fn lits(v: Vec3) -> [Sym; 3] {
    v.map(Sym::Lit)
}

/// A joint's axis (unit, base frame) and origin, as the Jacobian needs them.
struct JointAxis {
    axis: [Sym; 3],
    origin: [Sym; 3],
    prismatic: bool,
}

/// Emits `child = parent * step.origin * motion(q[var])` with names tagged `t`; with
/// `want_axis` also returns the joint's axis and origin in the base frame.
fn step(
    e: &mut Emitter,
    t: &str,
    parent: &SymFrame,
    step: &Step,
    want_axis: bool,
) -> (SymFrame, Option<JointAxis>) {
    // The joint frame: parent * origin.
    let origin_rot = step.origin.rot.map(|row| row.map(Sym::Lit));
    let rot = rot_product(e, &format!("r{t}_"), parent, &origin_rot);
    let offset = lits(step.origin.pos);
    let pos: [Sym; 3] = std::array::from_fn(|i| {
        let mut terms: Vec<(&Sym, &Sym)> =
            (0..3).map(|k| (&parent.rot[i][k], &offset[k])).collect();
        terms.push((&Sym::ONE, &parent.pos[i]));
        e.sum_of_products(&format!("p{t}_{i}"), &terms)
    });
    let joint = SymFrame { rot, pos };
    let (Some(var), axis) = (step.var, step.motion) else {
        return (joint, None);
    };
    let (axis, prismatic) = match axis {
        Motion::Revolute { axis } => (axis, false),
        Motion::Prismatic { axis } => (axis, true),
        Motion::Fixed => return (joint, None),
    };
    let world_axis = |e: &mut Emitter| rotate(e, &format!("w{t}_"), &joint, &lits(axis));
    let (child, axis_base) = if prismatic {
        let w = world_axis(e);
        let q = Sym::var(format!("q[{var}]"));
        let pos = std::array::from_fn(|i| {
            e.sum_of_products(
                &format!("q{t}_{i}"),
                &[(&Sym::ONE, &joint.pos[i]), (&w[i], &q)],
            )
        });
        (
            SymFrame {
                rot: joint.rot.clone(),
                pos,
            },
            Some(w),
        )
    } else {
        // Rodrigues: R = a aᵀ + c (I - a aᵀ) + s [a]ₓ, with literal coefficients, so an axis
        // along a coordinate axis leaves a sparse matrix and a cheap product.
        e.line(&format!("let (s{t}, c{t}) = ::libm::sincos(q[{var}]);"));
        let (s, c) = (Sym::var(format!("s{t}")), Sym::var(format!("c{t}")));
        let cross = [
            [0.0, -axis[2], axis[1]],
            [axis[2], 0.0, -axis[0]],
            [-axis[1], axis[0], 0.0],
        ];
        let m: [[Sym; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let aa = axis[i] * axis[j];
                let delta = f64::from(i == j);
                e.sum_of_products(
                    &format!("m{t}_{i}{j}"),
                    &[
                        (&Sym::Lit(aa), &Sym::ONE),
                        (&Sym::Lit(delta - aa), &c),
                        (&Sym::Lit(cross[i][j]), &s),
                    ],
                )
            })
        });
        let rot = rot_product(e, &format!("k{t}_"), &joint, &m);
        let w = want_axis.then(|| world_axis(e));
        (
            SymFrame {
                rot,
                pos: joint.pos.clone(),
            },
            w,
        )
    };
    let joint_axis = axis_base.filter(|_| want_axis).map(|axis| JointAxis {
        axis,
        origin: joint.pos.clone(),
        prismatic,
    });
    (child, joint_axis)
}

fn limit(v: f64) -> String {
    match v {
        f64::INFINITY => "f64::INFINITY".to_string(),
        f64::NEG_INFINITY => "f64::NEG_INFINITY".to_string(),
        v => lit(v),
    }
}

fn list<T>(items: impl IntoIterator<Item = T>, f: impl Fn(T) -> String) -> String {
    items.into_iter().map(f).collect::<Vec<_>>().join(", ")
}

fn fk_body(chain: &Chain) -> String {
    let mut e = Emitter::default();
    let mut frame = SymFrame::identity();
    for (i, s) in folded_steps(chain).iter().enumerate() {
        frame = step(&mut e, &i.to_string(), &frame, s, false).0;
    }
    e.line(&frame.code());
    e.code
}

fn link_frames_body(chain: &Chain) -> String {
    let mut e = Emitter::default();
    e.line(&format!(
        "debug_assert!(out.len() >= {});",
        chain.links.len()
    ));
    e.line("if let Some(slot) = out.get_mut(0) { *slot = crate::model::Frame::IDENTITY; }");
    let mut frame = SymFrame::identity();
    for (i, s) in all_steps(chain).iter().enumerate() {
        frame = step(&mut e, &i.to_string(), &frame, s, false).0;
        e.line(&format!(
            "if let Some(slot) = out.get_mut({}) {{ *slot = {}; }}",
            i + 1,
            frame.code()
        ));
    }
    e.line(&frame.code());
    e.code
}

fn jacobian_body(chain: &Chain, dof: usize) -> String {
    let mut e = Emitter::default();
    let mut frame = SymFrame::identity();
    let mut axes = Vec::new();
    for (i, s) in folded_steps(chain).iter().enumerate() {
        let (next, axis) = step(&mut e, &i.to_string(), &frame, s, true);
        frame = next;
        axes.extend(axis);
    }
    let tool = frame.pos.clone();
    let mut columns = Vec::new();
    for (j, a) in axes.iter().enumerate() {
        let w = &a.axis;
        let column: [Sym; 6] = if a.prismatic {
            [
                w[0].clone(),
                w[1].clone(),
                w[2].clone(),
                Sym::ZERO,
                Sym::ZERO,
                Sym::ZERO,
            ]
        } else {
            // linear velocity w × (tool - origin), angular velocity w
            let d: [Sym; 3] =
                std::array::from_fn(|i| e.sub(&format!("d{j}_{i}"), &tool[i], &a.origin[i]));
            let cross = |e: &mut Emitter, i: usize, x: usize, y: usize| {
                e.sum_of_products(
                    &format!("v{j}_{i}"),
                    &[(&w[x], &d[y]), (&w[y].neg(), &d[x])],
                )
            };
            let v = [
                cross(&mut e, 0, 1, 2),
                cross(&mut e, 1, 2, 0),
                cross(&mut e, 2, 0, 1),
            ];
            let [v0, v1, v2] = v;
            [v0, v1, v2, w[0].clone(), w[1].clone(), w[2].clone()]
        };
        columns.push(format!("[{}]", list(&column, Sym::code)));
    }
    e.line(&format!(
        "let jacobian = ::nalgebra::SMatrix::<f64, 6, {dof}>::from_array_storage(::nalgebra::ArrayStorage([{}]));",
        columns.join(", ")
    ));
    e.line(&format!("({}, jacobian)", frame.code()));
    e.code
}

pub fn model(
    type_name: &str,
    name: &str,
    source: &str,
    chain: &Chain,
    geometry: &Geometry,
) -> String {
    let actuated: Vec<_> = chain.actuated().collect();
    let d = actuated.len();
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(
        w,
        "/// Robot model `{name}`, generated by omcbsa-codegen from `{source}`."
    );
    let _ = writeln!(w, "#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]");
    let _ = writeln!(w, "pub struct {type_name};\n");
    let _ = writeln!(
        w,
        "#[allow(clippy::excessive_precision, clippy::unreadable_literal, clippy::approx_constant, \
         clippy::too_many_lines)]"
    );
    let _ = writeln!(w, "impl crate::model::Model<{d}> for {type_name} {{");
    let _ = writeln!(w, "    const NAME: &'static str = {name:?};");
    let _ = writeln!(
        w,
        "    const LINK_NAMES: &'static [&'static str] = &[{}];",
        list(&chain.links, |l| format!("{l:?}"))
    );
    let _ = writeln!(
        w,
        "    const JOINT_NAMES: [&'static str; {d}] = [{}];",
        list(&actuated, |j| format!("{:?}", j.name))
    );
    let _ = writeln!(
        w,
        "    const LOWER: [f64; {d}] = [{}];",
        list(&actuated, |j| limit(j.lower))
    );
    let _ = writeln!(
        w,
        "    const UPPER: [f64; {d}] = [{}];",
        list(&actuated, |j| limit(j.upper))
    );
    let _ = writeln!(
        w,
        "    const VELOCITY: [f64; {d}] = [{}];",
        list(&actuated, |j| lit(j.velocity))
    );
    let capsule = |c: &crate::collision::Capsule| {
        format!(
            "crate::model::LinkCapsule {{ link: {}, a: [{}], b: [{}], radius: {} }}",
            c.link,
            list(c.a, lit),
            list(c.b, lit),
            lit(c.radius)
        )
    };
    let _ = writeln!(
        w,
        "    const CAPSULES: &'static [crate::model::LinkCapsule] = &[{}];",
        list(&geometry.capsules, capsule)
    );
    let _ = writeln!(
        w,
        "    const SELF_PAIRS: &'static [(u8, u8)] = &[{}];",
        list(&geometry.self_pairs, |(a, b)| format!("({a}, {b})"))
    );
    let _ = writeln!(
        w,
        "    const REACH: [f64; {d}] = [{}];",
        list(&geometry.reach, |&r| limit(r))
    );
    let _ = writeln!(
        w,
        "    const CAPSULE_REACH: &'static [[f64; {d}]] = &[{}];",
        list(&geometry.capsule_reach, |row| format!(
            "[{}]",
            list(row, |&r| limit(r))
        ))
    );
    let _ = writeln!(w);
    let _ = writeln!(w, "    #[inline]");
    let _ = writeln!(
        w,
        "    fn fk(q: &[f64; {d}]) -> crate::model::Frame {{\n{}    }}\n",
        fk_body(chain)
    );
    let _ = writeln!(
        w,
        "    fn link_frames(q: &[f64; {d}], out: &mut [crate::model::Frame]) -> crate::model::Frame {{\n{}    }}\n",
        link_frames_body(chain)
    );
    let _ = writeln!(w, "    #[inline]");
    let _ = writeln!(
        w,
        "    fn jacobian(q: &[f64; {d}]) -> (crate::model::Frame, ::nalgebra::SMatrix<f64, 6, {d}>) {{\n{}    }}",
        jacobian_body(chain, d)
    );
    let _ = writeln!(w, "}}");
    out
}
