//! Numbers the kinematics and the batched collision kernel compute with: one `f64`, or
//! [`LANES`] of them at once ([`F64s`]), so that one body of code serves a single
//! configuration and a batch.
//!
//! Each lane of an [`F64s`] goes through exactly the operations one `f64` does, in the same
//! order: IEEE 754 addition, subtraction, multiplication, division and square root are
//! correctly rounded whatever the vector width, Rust never fuses a multiplication and an
//! addition on its own (no FMA contraction, no reassociation), and the comparisons and
//! selections here are written to give what the scalar code's `if`s give, NaN and signed zero
//! included. So a batch gives, bit for bit, what the configurations give one at a time, on
//! every target: the SIMD width changes the speed, never an answer.
//!
//! SIMD comes from `wide` (safe, `no_std`), which picks its instructions when the crate is
//! compiled, from the target's features: on x86_64 SSE2 by default (an [`F64s`] is four
//! 128-bit registers), AVX2 with `-C target-cpu=x86-64-v3` (two 256-bit registers), AVX-512
//! with `x86-64-v4` or `native` on a machine with it (one); on targets without SIMD, such as
//! `thumbv7em-none-eabihf`, plain arrays. The workspace builds x86_64 for `x86-64-v3`
//! (`.cargo/config.toml`: AVX2 and FMA, every x86_64 CPU since 2013-2015), the machines this
//! runs on; `RUSTFLAGS="-C target-cpu=x86-64"` gives a build for any x86_64, which batches
//! nothing ([`WIDE`]: with SSE2 a batch of 8 costs about as much as 8 single checks, and
//! loses their early exits). Compile-time selection keeps the core free of `unsafe`
//! (run-time dispatch needs `#[target_feature]` functions, called through `unsafe`) and costs
//! nothing per call. FMA being there changes nothing: Rust never fuses on its own.

use core::ops::{Add, Mul, Neg, Sub};

/// Configurations in one batch: one per lane of an [`F64s`].
pub const LANES: usize = 8;

/// Whether this build's SIMD is wide enough for batches to pay (AVX2: four lanes per
/// instruction). The planners batch their checks only then; answers are the same either way.
pub const WIDE: bool = cfg!(target_feature = "avx2");

/// [`LANES`] numbers at once.
pub type F64s = wide::f64x8;

/// A lane mask: bit `k` for lane `k`.
pub type Mask = u8;

/// Every lane.
pub const ALL: Mask = u8::MAX;

/// What the generated kinematics need of their numbers.
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    /// `v` in every lane.
    fn splat(v: f64) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
}

impl Real for F64s {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        F64s::splat(v)
    }
}

/// Lane `k` of `v`.
#[inline(always)]
pub fn lane(v: F64s, k: usize) -> f64 {
    v.as_array()[k]
}

/// The lanes of `mask`, lowest first.
#[inline]
pub fn lanes_of(mut mask: Mask) -> impl Iterator<Item = usize> {
    core::iter::from_fn(move || {
        (mask != 0).then(|| {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            k
        })
    })
}

/// Lanes where `a < b` (false where either is NaN).
#[inline(always)]
pub fn lt(a: F64s, b: F64s) -> Mask {
    a.simd_lt(b).to_bitmask() as Mask
}

/// Lanes where `a <= b` (false where either is NaN).
#[inline(always)]
pub fn le(a: F64s, b: F64s) -> Mask {
    a.simd_le(b).to_bitmask() as Mask
}

/// `if a < b { a } else { b }` in each lane, as [`crate::geometry::Aabb`] takes minima.
#[inline(always)]
pub fn min(a: F64s, b: F64s) -> F64s {
    a.simd_lt(b).select(a, b)
}

/// `if a > b { a } else { b }` in each lane.
#[inline(always)]
pub fn max(a: F64s, b: F64s) -> F64s {
    a.simd_gt(b).select(a, b)
}

/// `f64::max` in each lane: the other operand where one is NaN, else the larger; of two
/// zeros either (they compare equal, which is all the callers look at).
#[inline(always)]
pub fn max_num(a: F64s, b: F64s) -> F64s {
    // `a > b` is false where either is NaN: then `b`, unless `b` is the NaN.
    let b_nan = b.is_nan();
    b_nan.select(a, a.simd_gt(b).select(a, b))
}
