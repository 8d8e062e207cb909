//! Straight-line code emission over scalars that are either literals known at generation time
//! or named run-time variables. Products with a literal 0 vanish and products with ±1 become
//! plain (negated) variables, so known structure (a rotation about a coordinate axis, an
//! identity origin, a zero offset) costs nothing at run time without special-casing it. A sum
//! already bound, or its negation, is reused rather than computed again.

use std::collections::HashMap;
use std::fmt::Write;

#[derive(Clone, Debug, PartialEq)]
pub enum Sym {
    Lit(f64),
    Var { name: String, neg: bool },
}

impl Sym {
    pub const ZERO: Sym = Sym::Lit(0.0);
    pub const ONE: Sym = Sym::Lit(1.0);

    pub fn var(name: impl Into<String>) -> Sym {
        Sym::Var {
            name: name.into(),
            neg: false,
        }
    }

    pub fn neg(&self) -> Sym {
        match self {
            Sym::Lit(v) => Sym::Lit(-v),
            Sym::Var { name, neg } => Sym::Var {
                name: name.clone(),
                neg: !neg,
            },
        }
    }

    /// The Rust expression for this value, of type `f64`.
    pub fn code(&self) -> String {
        self.code_as(false)
    }

    /// The Rust expression for this value: of type `f64`, or of the generic number type `T`
    /// (`crate::trig::Angle`) if `generic`.
    pub fn code_as(&self, generic: bool) -> String {
        match self {
            Sym::Lit(v) => lit_as(*v, generic),
            Sym::Var { name, neg: false } => name.clone(),
            Sym::Var { name, neg: true } => format!("-{name}"),
        }
    }
}

/// A float literal with full round-trip precision (`{:?}` prints the shortest string that
/// parses back to the same `f64`, always with a `.` or an exponent).
pub fn lit(v: f64) -> String {
    format!("{v:?}")
}

/// [`lit`], as a value of the generic number type `T` if `generic`.
pub fn lit_as(v: f64, generic: bool) -> String {
    if generic {
        format!("T::splat({})", lit(v))
    } else {
        lit(v)
    }
}

/// Collects `let` bindings into a function body.
#[derive(Default)]
pub struct Emitter {
    pub code: String,
    /// Right-hand side of every binding -> its variable.
    bound: HashMap<String, Sym>,
    /// Whether the numbers are of a generic type `T: crate::trig::Angle` (literals become
    /// `T::splat(..)`), rather than `f64`. The operations and their order are the same.
    pub generic: bool,
}

impl Emitter {
    /// An emitter for a body generic over `T: crate::trig::Angle`.
    pub fn generic() -> Emitter {
        Emitter {
            generic: true,
            ..Emitter::default()
        }
    }

    pub fn line(&mut self, line: &str) {
        self.code.push_str("        ");
        self.code.push_str(line);
        self.code.push('\n');
    }

    /// `Σ a_k * b_k`, simplified; bound to a new variable `name` unless the result is a
    /// literal or a single (possibly negated) variable.
    pub fn sum_of_products(&mut self, name: &str, terms: &[(&Sym, &Sym)]) -> Sym {
        let mut constant = 0.0;
        // (negative, text, text is a single variable) for every run-time term
        let mut parts: Vec<(bool, String, bool)> = Vec::new();
        for (a, b) in terms {
            match (a, b) {
                (Sym::Lit(x), Sym::Lit(y)) => constant += x * y,
                (Sym::Lit(c), Sym::Var { name, neg }) | (Sym::Var { name, neg }, Sym::Lit(c)) => {
                    if *c == 0.0 {
                        continue;
                    }
                    let negative = (*c < 0.0) != *neg;
                    if c.abs() == 1.0 {
                        parts.push((negative, name.clone(), true));
                    } else {
                        let c = lit_as(c.abs(), self.generic);
                        parts.push((negative, format!("{c} * {name}"), false));
                    }
                }
                (Sym::Var { name: x, neg: nx }, Sym::Var { name: y, neg: ny }) => {
                    parts.push((nx != ny, format!("{x} * {y}"), false));
                }
            }
        }
        match (&parts[..], constant == 0.0) {
            ([], _) => return Sym::Lit(constant),
            ([(negative, text, true)], true) => {
                return Sym::Var {
                    name: text.clone(),
                    neg: *negative,
                };
            }
            _ => {}
        }
        let expr = sum_code(constant, &parts, false, self.generic);
        if let Some(v) = self.bound.get(&expr) {
            return v.clone();
        }
        if let Some(v) = self
            .bound
            .get(&sum_code(constant, &parts, true, self.generic))
        {
            return v.neg();
        }
        self.line(&format!("let {name} = {expr};"));
        self.bound.insert(expr, Sym::var(name));
        Sym::var(name)
    }

    /// `a - b`.
    pub fn sub(&mut self, name: &str, a: &Sym, b: &Sym) -> Sym {
        self.sum_of_products(name, &[(&Sym::ONE, a), (&Sym::Lit(-1.0), b)])
    }
}

/// `constant ± part ± ...`, every sign flipped if `negate`.
fn sum_code(constant: f64, parts: &[(bool, String, bool)], negate: bool, generic: bool) -> String {
    let mut expr = String::new();
    let constant = if negate { -constant } else { constant };
    if constant != 0.0 {
        expr.push_str(&lit_as(constant, generic));
    }
    for (i, (negative, text, _)) in parts.iter().enumerate() {
        let op = match (expr.is_empty() && i == 0, *negative != negate) {
            (true, false) => "",
            (true, true) => "-",
            (false, false) => " + ",
            (false, true) => " - ",
        };
        let _ = write!(expr, "{op}{text}");
    }
    expr
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literal_factors_simplify() {
        let mut e = Emitter::default();
        let x = Sym::var("x");
        let y = Sym::var("y");
        assert_eq!(
            e.sum_of_products("a", &[(&Sym::ZERO, &x), (&Sym::ONE, &y)]),
            y
        );
        assert_eq!(e.sum_of_products("b", &[(&Sym::Lit(-1.0), &x)]), x.neg());
        assert_eq!(
            e.sum_of_products("c", &[(&Sym::Lit(2.0), &Sym::Lit(3.0))]),
            Sym::Lit(6.0)
        );
        assert!(e.code.is_empty());
        let s = e.sum_of_products(
            "d",
            &[
                (&Sym::Lit(-0.5), &x),
                (&x.neg(), &y),
                (&Sym::ONE, &Sym::ONE),
            ],
        );
        assert_eq!(s, Sym::var("d"));
        assert_eq!(e.code.trim(), "let d = 1.0 - 0.5 * x - x * y;");
    }

    #[test]
    fn generic_literals_are_splats_in_the_same_expression() {
        let mut e = Emitter::generic();
        let (x, y) = (Sym::var("x"), Sym::var("y"));
        e.sum_of_products(
            "d",
            &[
                (&Sym::Lit(-0.5), &x),
                (&x.neg(), &y),
                (&Sym::ONE, &Sym::ONE),
            ],
        );
        assert_eq!(
            e.code.trim(),
            "let d = T::splat(1.0) - T::splat(0.5) * x - x * y;"
        );
        assert_eq!(Sym::Lit(-2.0).code_as(true), "T::splat(-2.0)");
    }

    #[test]
    fn a_bound_sum_or_its_negation_is_reused() {
        let mut e = Emitter::default();
        let (x, y) = (Sym::var("x"), Sym::var("y"));
        let two = Sym::Lit(2.0);
        let a = e.sum_of_products("a", &[(&two, &x), (&Sym::ONE, &y)]);
        assert_eq!(e.sum_of_products("b", &[(&two, &x), (&Sym::ONE, &y)]), a);
        let minus_two = Sym::Lit(-2.0);
        let minus_y = y.neg();
        assert_eq!(
            e.sum_of_products("c", &[(&minus_two, &x), (&Sym::ONE, &minus_y)]),
            a.neg()
        );
        assert_eq!(e.code.trim(), "let a = 2.0 * x + y;");
    }

    #[test]
    #[allow(clippy::approx_constant)] // 3.14159265358979 is a figure from Kinova's URDF
    fn literals_round_trip() {
        for v in [
            0.15643,
            2.7629e-18,
            -4.9305e-36,
            3.14159265358979,
            0.1 + 0.2,
        ] {
            assert_eq!(lit(v).parse::<f64>().unwrap().to_bits(), v.to_bits());
        }
    }
}
