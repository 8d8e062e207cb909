//! Rust source for one model: constants and the unrolled `fk`, `link_frames` and `jacobian`.
//!
//! Each step of the chain is a local transform `origin * motion(q)` whose entries are linear
//! in `(1, cos q, sin q)` (revolute) or `(1, q)` (prismatic), with coefficients computed here
//! ([`Local`]); the product of two steps is computed from those coefficients too. The sines
//! and cosines of all joints come first, from one call, independent of each other. `fk` and
//! `jacobian` walk a folded chain in which each run of fixed joints is merged into the next
//! joint's origin; `fk` also merges trailing fixed joints into the last joint and multiplies
//! the steps as a balanced tree of pairs, which halves the longest chain of dependent
//! products. `link_frames` walks every joint so it can report every link.

use std::fmt::Write;

use crate::chain::{Chain, Motion};
use crate::collision::Geometry;
use crate::sym::{lit, Emitter, Sym};
use crate::transform::{Mat3, Transform, Vec3};

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
    /// A `crate::model::Frame`, or with `generic` a `crate::model::FrameOf<T>`.
    fn code(&self, generic: bool) -> String {
        let code = |s: &Sym| s.code_as(generic);
        if generic {
            let rows: Vec<String> = (self.rot.iter())
                .map(|row| format!("[{}]", list(row, code)))
                .collect();
            format!(
                "crate::model::FrameOf {{ rot: [{}], pos: [{}] }}",
                rows.join(", "),
                list(&self.pos, code)
            )
        } else {
            format!(
                "crate::model::Frame {{ rot: ::nalgebra::Matrix3::new({}), pos: ::nalgebra::Vector3::new({}) }}",
                list(self.rot.iter().flatten(), code),
                list(&self.pos, code)
            )
        }
    }
}

/// `rot * v` for a literal `v`, each component bound to `{name}{i}`.
fn rotate(e: &mut Emitter, name: &str, rot: &[[Sym; 3]; 3], v: Vec3) -> [Sym; 3] {
    std::array::from_fn(|i| {
        let v = v.map(Sym::Lit);
        let terms: Vec<(&Sym, &Sym)> = (0..3).map(|k| (&rot[i][k], &v[k])).collect();
        e.sum_of_products(&format!("{name}{i}"), &terms)
    })
}

/// `a * b`, entries bound to `r{t}_{i}{j}` and `p{t}_{i}`.
fn compose(e: &mut Emitter, t: &str, a: &SymFrame, b: &SymFrame) -> SymFrame {
    let rot = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let terms: Vec<(&Sym, &Sym)> = (0..3).map(|k| (&a.rot[i][k], &b.rot[k][j])).collect();
            e.sum_of_products(&format!("r{t}_{i}{j}"), &terms)
        })
    });
    let pos = std::array::from_fn(|i| {
        let mut terms: Vec<(&Sym, &Sym)> = (0..3).map(|k| (&a.rot[i][k], &b.pos[k])).collect();
        terms.push((&Sym::ONE, &a.pos[i]));
        e.sum_of_products(&format!("p{t}_{i}"), &terms)
    });
    SymFrame { rot, pos }
}

fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// A transform whose entries are linear in a basis with coefficients known here: entry `x`
/// stands for `Σ x[k] * basis[k]`, and `basis[0]` is 1. A step's own transform
/// `origin * motion(q)` is one, with basis `(1, c, s)` (revolute) or `(1, q)` (prismatic).
#[derive(Clone)]
struct Local {
    basis: Vec<Sym>,
    rot: [[Vec<f64>; 3]; 3],
    pos: [Vec<f64>; 3],
}

/// Per entry of a product `a * b`, per element of `b`'s basis, a vector over `a`'s basis.
struct Grouped {
    rot: [[Vec<Vec<f64>>; 3]; 3],
    pos: [Vec<Vec<f64>>; 3],
}

impl Local {
    fn literal(t: &Transform) -> Local {
        Local {
            basis: vec![Sym::ONE],
            rot: t.rot.map(|row| row.map(|r| vec![r])),
            pos: t.pos.map(|p| vec![p]),
        }
    }

    /// The step's transform; the joint's sine and cosine are `s{var}` and `c{var}` (see
    /// [`sincos`]).
    fn of(step: &Step) -> Local {
        let o = &step.origin;
        match (step.motion, step.var) {
            (Motion::Revolute { axis: a }, Some(var)) => {
                // Rodrigues: R = a aᵀ + c (I - a aᵀ) + s [a]ₓ.
                let aat: Mat3 = std::array::from_fn(|i| std::array::from_fn(|j| a[i] * a[j]));
                let rest =
                    std::array::from_fn(|i| std::array::from_fn(|j| f64::from(i == j) - aat[i][j]));
                let cross = [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]];
                let parts = [aat, rest, cross].map(|m| mat_mul(&o.rot, &m));
                Local {
                    basis: vec![
                        Sym::ONE,
                        Sym::var(format!("c{var}")),
                        Sym::var(format!("s{var}")),
                    ],
                    rot: std::array::from_fn(|i| {
                        std::array::from_fn(|j| parts.iter().map(|m| m[i][j]).collect())
                    }),
                    pos: o.pos.map(|p| vec![p, 0.0, 0.0]),
                }
            }
            (Motion::Prismatic { axis }, Some(var)) => {
                let along = o.rotate(axis);
                Local {
                    basis: vec![Sym::ONE, Sym::var(format!("q[{var}]"))],
                    rot: o.rot.map(|row| row.map(|r| vec![r, 0.0])),
                    pos: std::array::from_fn(|i| vec![o.pos[i], along[i]]),
                }
            }
            _ => Local::literal(o),
        }
    }

    fn is_literal(&self) -> bool {
        self.basis.len() == 1
    }

    fn grouped(&self, b: &Local) -> Grouped {
        let n = self.basis.len();
        let group = |terms: &[(&Vec<f64>, f64)]| -> Vec<f64> {
            (0..n)
                .map(|m| terms.iter().map(|(x, w)| x[m] * w).sum())
                .collect()
        };
        Grouped {
            rot: std::array::from_fn(|i| {
                std::array::from_fn(|col| {
                    (0..b.basis.len())
                        .map(|j| {
                            let terms: Vec<_> = (0..3)
                                .map(|k| (&self.rot[i][k], b.rot[k][col][j]))
                                .collect();
                            group(&terms)
                        })
                        .collect()
                })
            }),
            pos: std::array::from_fn(|i| {
                (0..b.basis.len())
                    .map(|j| {
                        let mut terms: Vec<_> =
                            (0..3).map(|k| (&self.rot[i][k], b.pos[k][j])).collect();
                        if j == 0 {
                            terms.push((&self.pos[i], 1.0));
                        }
                        group(&terms)
                    })
                    .collect()
            }),
        }
    }

    /// `self * b` when at most one of them varies, so that it is a local too.
    fn compose(&self, b: &Local) -> Option<Local> {
        let g = self.grouped(b);
        if b.is_literal() {
            Some(Local {
                basis: self.basis.clone(),
                rot: g.rot.map(|row| row.map(|mut groups| groups.remove(0))),
                pos: g.pos.map(|mut groups| groups.remove(0)),
            })
        } else if self.is_literal() {
            let flat = |groups: Vec<Vec<f64>>| groups.into_iter().map(|v| v[0]).collect();
            Some(Local {
                basis: b.basis.clone(),
                rot: g.rot.map(|row| row.map(flat)),
                pos: g.pos.map(flat),
            })
        } else {
            None
        }
    }

    /// `Σ coefs[k] * basis[k]`, bound to `name`. Coefficients below `2^-53` are left out:
    /// rounding noise in a URDF's angles leaves many (Kinova's `rpy="1.5708 2.1343E-17
    /// -1.1102E-16"`), each costing a product, and each changes the unit-scale sum it is part
    /// of by less than that sum's own rounding.
    fn entry(&self, e: &mut Emitter, name: &str, coefs: &[f64]) -> Sym {
        let coefs: Vec<Sym> = coefs
            .iter()
            .map(|&c| Sym::Lit(if c.abs() < f64::EPSILON / 2.0 { 0.0 } else { c }))
            .collect();
        let terms: Vec<(&Sym, &Sym)> = coefs.iter().zip(&self.basis).collect();
        e.sum_of_products(name, &terms)
    }

    /// `rot * v` for a literal `v`, each component bound to `{name}{i}`.
    fn rotate(&self, e: &mut Emitter, name: &str, v: Vec3) -> [Sym; 3] {
        std::array::from_fn(|i| {
            let coefs: Vec<f64> = (0..self.basis.len())
                .map(|m| (0..3).map(|k| self.rot[i][k][m] * v[k]).sum())
                .collect();
            self.entry(e, &format!("{name}{i}"), &coefs)
        })
    }

    /// Entries bound to `m{t}_{i}{j}` and `o{t}_{i}`.
    fn emit(&self, e: &mut Emitter, t: &str) -> SymFrame {
        SymFrame {
            rot: std::array::from_fn(|i| {
                std::array::from_fn(|j| self.entry(e, &format!("m{t}_{i}{j}"), &self.rot[i][j]))
            }),
            pos: self.emit_pos(e, t),
        }
    }

    fn emit_pos(&self, e: &mut Emitter, t: &str) -> [Sym; 3] {
        std::array::from_fn(|i| self.entry(e, &format!("o{t}_{i}"), &self.pos[i]))
    }

    /// `self * b`, each entry `Σ_j b.basis[j] * g_j` where every `g_j` is linear in `self`'s
    /// basis with known coefficients. Cheaper than emitting both and multiplying: `self`
    /// times each of `b`'s (constant) columns costs one product per basis element instead of
    /// three, and the columns a rotation shares are computed once. Entries bound to
    /// `r{t}_{i}{j}` and `p{t}_{i}`, the groups to `g{t}_...`.
    fn emit_product(&self, e: &mut Emitter, t: &str, b: &Local) -> SymFrame {
        let g = self.grouped(b);
        let entry = |e: &mut Emitter, kind: &str, index: String, groups: &[Vec<f64>]| {
            let parts: Vec<Sym> = groups
                .iter()
                .enumerate()
                .map(|(j, coefs)| self.entry(e, &format!("g{t}_{kind}{index}_{j}"), coefs))
                .collect();
            let terms: Vec<(&Sym, &Sym)> = b.basis.iter().zip(&parts).collect();
            e.sum_of_products(&format!("{kind}{t}_{index}"), &terms)
        };
        SymFrame {
            rot: std::array::from_fn(|i| {
                std::array::from_fn(|j| entry(e, "r", format!("{i}{j}"), &g.rot[i][j]))
            }),
            pos: std::array::from_fn(|i| entry(e, "p", i.to_string(), &g.pos[i])),
        }
    }
}

/// `s{var}` and `c{var}` for every revolute step, from one call ahead of everything else:
/// they are independent, so they overlap each other and the first products.
fn sincos(e: &mut Emitter, steps: &[Step]) {
    let vars: Vec<usize> = steps
        .iter()
        .filter_map(|s| match (s.motion, s.var) {
            (Motion::Revolute { .. }, Some(var)) => Some(var),
            _ => None,
        })
        .collect();
    if !vars.is_empty() {
        e.line(&format!(
            "let ([{}], [{}]) = crate::trig::sincos([{}]);",
            list(&vars, |v| format!("s{v}")),
            list(&vars, |v| format!("c{v}")),
            list(&vars, |v| format!("q[{v}]"))
        ));
    }
}

/// A frame along a chain: a local while at most one joint has moved it, then emitted.
enum Frame {
    Local(Local),
    Emitted(SymFrame),
}

impl Frame {
    /// `self * local`, products tagged `t`.
    fn then(&self, e: &mut Emitter, t: &str, local: &Local) -> Frame {
        match self {
            Frame::Local(a) => a
                .compose(local)
                .map_or_else(|| Frame::Emitted(a.emit_product(e, t, local)), Frame::Local),
            Frame::Emitted(a) => {
                let b = local.emit(e, t);
                Frame::Emitted(compose(e, t, a, &b))
            }
        }
    }

    fn emit(&self, e: &mut Emitter, t: &str) -> SymFrame {
        match self {
            Frame::Local(l) => l.emit(e, t),
            Frame::Emitted(f) => f.clone(),
        }
    }

    fn pos(&self, e: &mut Emitter, t: &str) -> [Sym; 3] {
        match self {
            Frame::Local(l) => l.emit_pos(e, t),
            Frame::Emitted(f) => f.pos.clone(),
        }
    }

    /// `rot * v` for a literal `v`, each component bound to `{name}{i}`.
    fn rotate(&self, e: &mut Emitter, name: &str, v: Vec3) -> [Sym; 3] {
        match self {
            Frame::Local(l) => l.rotate(e, name, v),
            Frame::Emitted(f) => rotate(e, name, &f.rot, v),
        }
    }
}

/// The product of `locals`, which start at step `first`: adjacent pairs multiplied as
/// [`Local::emit_product`], the pairs as a balanced tree. Products tagged `{first}_{end}`.
fn product(e: &mut Emitter, locals: &[Local], first: usize) -> SymFrame {
    let tag = format!("{first}_{}", first + locals.len());
    match locals {
        [l] => l.emit(e, &first.to_string()),
        [a, b] => match a.compose(b) {
            Some(l) => l.emit(e, &tag),
            None => a.emit_product(e, &tag, b),
        },
        _ => {
            // An even split keeps pairs together.
            let half = locals.len().div_ceil(4) * 2;
            let a = product(e, &locals[..half], first);
            let b = product(e, &locals[half..], first + half);
            compose(e, &tag, &a, &b)
        }
    }
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

/// The body of `fk_of<T>`: the tool frame.
fn fk_body(chain: &Chain) -> String {
    let mut e = Emitter::generic();
    let mut steps = folded_steps(chain);
    sincos(&mut e, &steps);
    let tool = match steps.last() {
        Some(s) if s.var.is_none() => steps.pop(),
        _ => None,
    };
    let mut locals: Vec<Local> = steps.iter().map(Local::of).collect();
    if let (Some(tool), Some(last)) = (tool, locals.last_mut()) {
        *last = last
            .compose(&Local::literal(&tool.origin))
            .expect("a literal factor keeps a local");
    }
    let frame = product(&mut e, &locals, 0);
    e.line(&frame.code(true));
    e.code
}

/// The body of `link_frames_of<T, B>`: hands every link frame to `out` (with its index) as
/// it is computed, and returns the tool frame; stops, computing no further frame, when `out`
/// breaks. The joints' sines and cosines all first (what one configuration's latency wants:
/// they overlap), or with `stepwise` each as its frame needs it (what a batch that may stop
/// early wants: none past the stop).
fn link_frames_body(chain: &Chain, stepwise: bool) -> String {
    let mut e = Emitter::generic();
    let steps = all_steps(chain);
    if !stepwise {
        sincos(&mut e, &steps);
    }
    e.line("out(0, &crate::model::FrameOf::identity())?;");
    let mut frame = Frame::Local(Local::literal(&Transform::IDENTITY));
    for (i, s) in steps.iter().enumerate() {
        let t = i.to_string();
        if stepwise {
            sincos(&mut e, core::slice::from_ref(s));
        }
        frame = frame.then(&mut e, &t, &Local::of(s));
        let code = frame.emit(&mut e, &t).code(true);
        e.line(&format!("let f{t} = {code};"));
        e.line(&format!("out({}, &f{t})?;", i + 1));
    }
    match steps.len() {
        0 => e.line("::core::ops::ControlFlow::Continue(crate::model::FrameOf::identity())"),
        n => e.line(&format!("::core::ops::ControlFlow::Continue(f{})", n - 1)),
    }
    e.code
}

/// A joint's axis (unit, base frame) and origin, as the Jacobian needs them.
struct JointAxis {
    axis: [Sym; 3],
    origin: [Sym; 3],
    prismatic: bool,
}

fn jacobian_body(chain: &Chain, dof: usize) -> String {
    let mut e = Emitter::default();
    let steps = folded_steps(chain);
    sincos(&mut e, &steps);
    let mut frame = Frame::Local(Local::literal(&Transform::IDENTITY));
    let mut axes = Vec::new();
    for (i, s) in steps.iter().enumerate() {
        let t = i.to_string();
        let next = frame.then(&mut e, &t, &Local::of(s));
        let moving = match s.motion {
            Motion::Revolute { axis } => Some((axis, false)),
            Motion::Prismatic { axis } => Some((axis, true)),
            Motion::Fixed => None,
        };
        if let Some((axis, prismatic)) = moving {
            axes.push(JointAxis {
                axis: frame.rotate(&mut e, &format!("w{i}_"), s.origin.rotate(axis)),
                // The motion leaves a revolute joint's origin where it is.
                origin: next.pos(&mut e, &t),
                prismatic,
            });
        }
        frame = next;
    }
    let frame = frame.emit(&mut e, "tool");
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
        columns.push(format!("[{}]", list(&column, |s: &Sym| s.code())));
    }
    e.line(&format!(
        "let jacobian = ::nalgebra::SMatrix::<f64, 6, {dof}>::from_array_storage(::nalgebra::ArrayStorage([{}]));",
        columns.join(", ")
    ));
    e.line(&format!("({}, jacobian)", frame.code(false)));
    e.code
}

pub fn model(
    type_name: &str,
    name: &str,
    source: &str,
    chain: &Chain,
    acceleration: &[f64],
    limits_source: Option<&str>,
    geometry: &Geometry,
) -> String {
    let d = chain.actuated().count();
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(
        w,
        "/// Robot model `{name}`, generated by omcbsa-codegen from `{source}`."
    );
    if let Some(source) = limits_source {
        let _ = writeln!(
            w,
            "///\n/// Velocity and acceleration limits: {}",
            source.replace('\n', " ")
        );
    }
    let _ = writeln!(w, "#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]");
    let _ = writeln!(w, "pub struct {type_name};\n");
    kinematics_impl(w, type_name, chain, d);
    let _ = writeln!(
        w,
        "#[allow(clippy::excessive_precision, clippy::unreadable_literal, clippy::approx_constant, \
         clippy::too_many_lines)]"
    );
    let _ = writeln!(w, "impl crate::model::Model<{d}> for {type_name} {{");
    model_constants(w, name, chain, acceleration, geometry);
    model_methods(w, chain, d);
    let _ = writeln!(w, "}}");
    out
}

/// The model type's own kinematics (`fk_of`, `link_frames_of`, `link_frames_stepwise_of`).
fn kinematics_impl(w: &mut String, type_name: &str, chain: &Chain, d: usize) {
    // The kinematics once, over any `Real`: one configuration (`f64`) and a batch (`F64s`)
    // run the same operations in the same order, so a batch's lanes equal single calls.
    let _ = writeln!(
        w,
        "#[allow(clippy::excessive_precision, clippy::unreadable_literal, clippy::approx_constant, \
         clippy::too_many_lines)]"
    );
    let _ = writeln!(w, "impl {type_name} {{");
    let _ = writeln!(
        w,
        "    /// [`crate::model::Model::fk`] over any numbers.\n    #[inline(always)]\n    \
         pub fn fk_of<T: crate::trig::Angle>(q: &[T; {d}]) -> crate::model::FrameOf<T> {{\n{}    }}\n",
        fk_body(chain)
    );
    let _ = writeln!(
        w,
        "    /// [`crate::model::Model::link_frames`] over any numbers: link frame `i` goes to \
         `out(i, ..)`, and once `out` breaks no further frame is computed.\n    #[inline(always)]\n    \
         pub fn link_frames_of<T: crate::trig::Angle, B>(q: &[T; {d}], mut out: impl FnMut(usize, &crate::model::FrameOf<T>) -> ::core::ops::ControlFlow<B>) \
         -> ::core::ops::ControlFlow<B, crate::model::FrameOf<T>> {{\n{}    }}\n",
        link_frames_body(chain, false)
    );
    let _ = writeln!(
        w,
        "    /// `link_frames_of` with each joint's sine and cosine computed as its frame needs \
         it: a caller that stops early computes none past the stop.\n    #[inline(always)]\n    \
         pub fn link_frames_stepwise_of<T: crate::trig::Angle, B>(q: &[T; {d}], mut out: impl FnMut(usize, &crate::model::FrameOf<T>) -> ::core::ops::ControlFlow<B>) \
         -> ::core::ops::ControlFlow<B, crate::model::FrameOf<T>> {{\n{}    }}",
        link_frames_body(chain, true)
    );
    let _ = writeln!(w, "}}\n");
}

/// The constants of `impl Model` (`NAME` to `AXIS_COS`).
fn model_constants(
    w: &mut String,
    name: &str,
    chain: &Chain,
    acceleration: &[f64],
    geometry: &Geometry,
) {
    let actuated: Vec<_> = chain.actuated().collect();
    let d = actuated.len();
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
    let _ = writeln!(
        w,
        "    const ACCELERATION: [f64; {d}] = [{}];",
        list(acceleration, |&a| limit(a))
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
    let _ = writeln!(
        w,
        "    const TOOL_SELF_CAPSULES: &'static [u8] = &[{}];",
        list(&geometry.tool_self_capsules, |i| i.to_string())
    );
    let _ = writeln!(
        w,
        "    const TOOL_REACH: [f64; {d}] = [{}];",
        list(&geometry.tool_reach, |&r| limit(r))
    );
    let _ = writeln!(
        w,
        "    const AXIS_COS: [f64; {d}] = [{}];",
        list(&geometry.axis_cos, |&c| lit(c))
    );
    let _ = writeln!(w);
}

/// The methods of `impl Model` (`fk` to `jacobian`).
fn model_methods(w: &mut String, chain: &Chain, d: usize) {
    let links = chain.links.len();
    let _ = writeln!(
        w,
        "    #[inline]\n    fn fk(q: &[f64; {d}]) -> crate::model::Frame {{\n        \
         Self::fk_of(q).into()\n    }}\n"
    );
    let _ = writeln!(
        w,
        "    fn link_frames(q: &[f64; {d}], out: &mut [crate::model::Frame]) -> crate::model::Frame {{\n        \
         debug_assert!(out.len() >= {links});\n        \
         let ::core::ops::ControlFlow::<::core::convert::Infallible, _>::Continue(tool) = \
         Self::link_frames_of(q, |i, f| {{ if let Some(slot) = out.get_mut(i) {{ *slot = f.into(); }} ::core::ops::ControlFlow::Continue(()) }});\n        \
         tool.into()\n    }}\n"
    );
    let _ = writeln!(
        w,
        "    #[inline]\n    fn fk_lanes(q: &[crate::lanes::F64s; {d}]) -> crate::model::FrameOf<crate::lanes::F64s> {{\n        \
         Self::fk_of(q)\n    }}\n"
    );
    let _ = writeln!(
        w,
        "    #[inline]\n    fn link_frames_lanes(q: &[crate::lanes::F64s; {d}], out: impl crate::model::LinkSink) \
         -> ::core::ops::ControlFlow<(), crate::model::FrameOf<crate::lanes::F64s>> {{\n        \
         Self::link_frames_stepwise_of(q, out)\n    }}\n"
    );
    let _ = writeln!(w, "    #[inline]");
    let _ = writeln!(
        w,
        "    fn jacobian(q: &[f64; {d}]) -> (crate::model::Frame, ::nalgebra::SMatrix<f64, 6, {d}>) {{\n{}    }}",
        jacobian_body(chain, d)
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_below_rounding_vanish() {
        // Kinova-style noise in the origin: the joint is a plain rotation about z.
        let step = Step {
            origin: Transform::from_xyz_rpy([0.0; 3], [2e-17, -1e-16, 5e-33]),
            motion: Motion::Revolute {
                axis: [0.0, 0.0, 1.0],
            },
            var: Some(0),
        };
        let mut e = Emitter::default();
        let frame = Local::of(&step).emit(&mut e, "0");
        assert!(e.code.is_empty(), "{}", e.code);
        let (c, s) = (Sym::var("c0"), Sym::var("s0"));
        let expected = [
            [c.clone(), s.neg(), Sym::ZERO],
            [s, c, Sym::ZERO],
            [Sym::ZERO, Sym::ZERO, Sym::ONE],
        ];
        assert_eq!(frame.rot, expected);
    }
}
