//! Sines and cosines of all joint angles at once, for the generated kinematics.
//!
//! They are the first thing `fk` needs and the last thing its product can wait for, so what
//! counts is latency. `libm::sincos` reduces by pi/2 and then runs degree-13 polynomials one
//! step after another. Here `x = n pi/32 + r` with `|r| <= pi/64`: polynomials of degree 7 and
//! 6 in `r`, and `sin`, `cos` of `n pi/32` from a table, joined by the angle-sum formulas. No
//! branch depends on the angles except one test that all of them are in range. Within 2 ulp
//! of the exact values (about 1e-16 absolute) for `|x| <= LIMIT`; beyond that, and for NaN and
//! infinities, it is `libm::sincos`. Generic over [`Angle`]: a batch of angles ([`F64s`]) goes
//! through the same operations lane by lane, so it gives what each angle gives alone.

use crate::lanes::{F64s, Real, LANES};

/// With `|x| <= LIMIT`, `n = round(x * 32/pi) < 2^20`, so `n * STEP_HI` and `n * STEP_MID`
/// are exact (33 + 20 bits) and the reduction loses nothing to cancellation.
const LIMIT: f64 = 1e5;
/// `pi/32 = STEP_HI + STEP_MID + STEP_LO` (to 1e-38), the first two with 33 significant bits.
const STEP_HI: f64 = 0.09817477042088285;
const STEP_MID: f64 = 3.798187816439979e-12;
const STEP_LO: f64 = 1.2639164054974691e-22;
/// `32/pi`.
const INV_STEP: f64 = 10.185916357881302;
/// `1.5 * 2^52`: adding it rounds to an integer, which lands in the low mantissa bits.
const ROUND: f64 = 6_755_399_441_055_744.0;
/// `sin(j pi/32)` for `j = 0..=16`, correctly rounded.
const QUARTER: [f64; 17] = [
    0.0,
    0.0980171403295606,
    0.19509032201612828,
    0.2902846772544624,
    0.3826834323650898,
    0.47139673682599764,
    0.5555702330196022,
    0.6343932841636455,
    core::f64::consts::FRAC_1_SQRT_2,
    0.773010453362737,
    0.8314696123025452,
    0.881921264348355,
    0.9238795325112867,
    0.9569403357322088,
    0.9807852804032304,
    0.9951847266721969,
    1.0,
];
/// `[sin(j pi/32), cos(j pi/32)]` for `j = 0..64`: one load for both.
const TABLE: [[f64; 2]; 64] = full_turn();
/// `sin(r) = r + r^3 * SIN(r^2)` (relative error 8.5e-19) and
/// `cos(r) = 1 - r^2/2 + r^4 * COS(r^2)` (absolute error 1.6e-17) for `|r| <= pi/64`:
/// minimax fits, constant term first.
const SIN: [f64; 3] = [
    -0.16666666666665958,
    0.00833333331549926,
    -0.00019839993712521045,
];
const COS: [f64; 2] = [0.041666666583424376, -0.001388795701842795];

const fn full_turn() -> [[f64; 2]; 64] {
    const fn sin(j: usize) -> f64 {
        let k = j % 32;
        let v = if k <= 16 { QUARTER[k] } else { QUARTER[32 - k] };
        if j % 64 < 32 {
            v
        } else {
            -v
        }
    }
    let mut table = [[0.0; 2]; 64];
    let mut j = 0;
    while j < 64 {
        table[j] = [sin(j), sin(j + 16)];
        j += 1;
    }
    table
}

/// What the reduction needs of its numbers beyond arithmetic: one `f64` or a batch of them
/// ([`F64s`]), lane by lane the same operations.
pub trait Angle: Real {
    /// `[sin, cos]` of `j pi/32`, `j` the low 6 bits of each lane of `shifted`.
    fn turn(shifted: Self) -> (Self, Self);
    /// Whether every lane is within `LIMIT` (NaN is not).
    fn in_range(self) -> bool;
    /// `(sin, cos)` of each lane through `one`.
    fn each(self) -> (Self, Self);
}

impl Angle for f64 {
    #[inline(always)]
    fn turn(shifted: f64) -> (f64, f64) {
        // n mod 64, from the low mantissa bits (two's complement, so negative n works too).
        let [s, c] = TABLE[(shifted.to_bits() & 63) as usize];
        (s, c)
    }

    #[inline(always)]
    fn in_range(self) -> bool {
        self.abs() <= LIMIT
    }

    #[inline(always)]
    fn each(self) -> (f64, f64) {
        one(self)
    }
}

impl Angle for F64s {
    #[inline(always)]
    fn turn(shifted: F64s) -> (F64s, F64s) {
        let bits = shifted.to_array();
        let (mut s, mut c) = ([0.0; LANES], [0.0; LANES]);
        for k in 0..LANES {
            (s[k], c[k]) = f64::turn(bits[k]);
        }
        (F64s::new(s), F64s::new(c))
    }

    #[inline(always)]
    fn in_range(self) -> bool {
        self.abs().simd_le(F64s::splat(LIMIT)).all()
    }

    fn each(self) -> (F64s, F64s) {
        let x = self.to_array();
        let (mut s, mut c) = ([0.0; LANES], [0.0; LANES]);
        for k in 0..LANES {
            (s[k], c[k]) = one(x[k]);
        }
        (F64s::new(s), F64s::new(c))
    }
}

/// `(sin x, cos x)` for `|x| <= LIMIT`.
#[inline(always)]
fn reduced<T: Angle>(x: T) -> (T, T) {
    let c = T::splat;
    let shifted = x * c(INV_STEP) + c(ROUND);
    let n = shifted - c(ROUND);
    let r = ((x - n * c(STEP_HI)) - n * c(STEP_MID)) - n * c(STEP_LO);
    let z = r * r;
    // Estrin's scheme: shorter than Horner's, and this is on the critical path.
    let sin_r = r + r * z * ((c(SIN[0]) + c(SIN[1]) * z) + c(SIN[2]) * (z * z));
    let cos_r_minus_1 = z * (c(-0.5) + z * (c(COS[0]) + c(COS[1]) * z));
    let (s, c) = T::turn(shifted);
    // The table entry plus a small correction, which keeps the rounding error near 1 ulp.
    (
        s + (s * cos_r_minus_1 + c * sin_r),
        c + (c * cos_r_minus_1 - s * sin_r),
    )
}

/// `(sin x, cos x)` of one angle, any.
fn one(x: f64) -> (f64, f64) {
    if x.in_range() {
        reduced(x)
    } else {
        libm::sincos(x)
    }
}

/// `(sin, cos)` of each angle, element by element (each lane of a batch as alone). Always
/// inlined: LLVM judges it too big, but called, its results come back through memory and the
/// caller's products wait for the last of them. The rare path stays inline too: moved out of
/// line, it measured slower.
#[inline(always)]
pub fn sincos<T: Angle, const N: usize>(x: [T; N]) -> ([T; N], [T; N]) {
    let mut sin = [T::splat(0.0); N];
    let mut cos = [T::splat(0.0); N];
    if x.iter().all(|v| v.in_range()) {
        for i in 0..N {
            (sin[i], cos[i]) = reduced(x[i]);
        }
    } else {
        for i in 0..N {
            (sin[i], cos[i]) = if x[i].in_range() {
                reduced(x[i])
            } else {
                x[i].each()
            };
        }
    }
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use core::f64::consts::{FRAC_PI_2, PI};

    use super::*;
    use crate::rng::Rng;

    fn ulp(v: f64) -> f64 {
        let a = v.abs();
        f64::from_bits(a.to_bits() + 1) - a
    }

    fn assert_close(x: f64) {
        let ([s], [c]) = sincos([x]);
        let (ls, lc) = libm::sincos(x);
        for (got, want) in [(s, ls), (c, lc)] {
            assert!(
                (got - want).abs() <= 3.0 * ulp(want),
                "sincos({x:e}) = ({s:e}, {c:e}), libm ({ls:e}, {lc:e})"
            );
        }
    }

    #[test]
    fn constants_are_pi() {
        for part in [STEP_HI, STEP_MID] {
            assert!(part.to_bits().trailing_zeros() >= 53 - 33, "{part:e}");
        }
        // pi/32 - PI/32, the rounding error of the double closest to pi/32.
        let tail = 3.827021247335479e-18;
        assert!(((STEP_HI - PI / 32.0) + STEP_MID + STEP_LO - tail).abs() < 1e-33);
        assert!(LIMIT * INV_STEP < f64::from(1u32 << 20));
        assert!((INV_STEP - 32.0 / PI).abs() <= ulp(INV_STEP));
        // libm is off by the rounding of its argument too: up to 1e-16 below pi/2, 7e-16
        // near 2 pi.
        for (j, [s, c]) in TABLE.iter().enumerate() {
            let (ls, lc) = libm::sincos(j as f64 * PI / 32.0);
            let tolerance = if j <= 16 { 2.5e-16 } else { 8e-16 };
            assert!(
                (s - ls).abs() <= tolerance && (c - lc).abs() <= tolerance,
                "sincos({j} pi/32): ({s:e}, {c:e}), libm ({ls:e}, {lc:e})"
            );
        }
    }

    #[test]
    fn matches_libm() {
        let mut rng = Rng::new(7);
        for scale in [0.1, 1.0, 4.0, 100.0, LIMIT] {
            for _ in 0..100_000 {
                assert_close(rng.uniform(-scale, scale));
            }
        }
        // Table and quadrant boundaries and near-zeros, a few ulp either side.
        for k in -4000..=4000 {
            for base in [f64::from(k) * PI / 64.0, f64::from(k) * FRAC_PI_2] {
                let mut x = base;
                for _ in 0..4 {
                    assert_close(x);
                    assert_close(-x);
                    x = f64::from_bits(x.to_bits() + 1);
                }
            }
        }
        for x in [0.0, -0.0, 1e-300, 5e-324, 1e-8, LIMIT, -LIMIT] {
            assert_close(x);
        }
    }

    #[test]
    fn falls_back_to_libm_out_of_range() {
        let x = [0.5, LIMIT * (1.0 + f64::EPSILON), -2e6, 1e22, -1e300];
        let (s, c) = sincos(x);
        assert_eq!((s[0], c[0]), reduced(0.5), "in range, the same as alone");
        for i in 1..x.len() {
            assert_eq!((s[i], c[i]), libm::sincos(x[i]));
        }
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let ([s], [c]) = sincos([x]);
            assert!(s.is_nan() && c.is_nan());
        }
    }
}
