//! Derivative-free minimisation (Nelder-Mead). The capsule volume as a function of the axis is
//! continuous but not smooth (the enclosing radius is a max over points), so a simplex search
//! suits it better than gradients.

/// Minimises `f` from `start`, with the initial simplex spanned by `step` along each
/// coordinate. Stops after `max_evals` evaluations or when the simplex's values agree to a
/// relative 1e-10. Deterministic: the same inputs give the same result.
pub fn nelder_mead<const N: usize>(
    f: impl Fn(&[f64; N]) -> f64,
    start: [f64; N],
    step: [f64; N],
    max_evals: usize,
) -> ([f64; N], f64) {
    let mut simplex: Vec<([f64; N], f64)> = (0..=N)
        .map(|i| {
            let mut x = start;
            if i > 0 {
                x[i - 1] += step[i - 1];
            }
            (x, f(&x))
        })
        .collect();
    let mut evals = N + 1;
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, second_worst, worst) = (simplex[0].1, simplex[N - 1].1, simplex[N].1);
        if worst - best <= 1e-10 * best.abs() {
            break;
        }
        let mut centroid = [0.0; N];
        for (x, _) in &simplex[..N] {
            for (c, xi) in centroid.iter_mut().zip(x) {
                *c += xi / N as f64;
            }
        }
        let worst_x = simplex[N].0;
        // The point centroid + t * (worst - centroid): t = -1 reflects, -2 expands, +-0.5
        // contracts.
        let along = |t: f64| -> [f64; N] {
            let mut x = centroid;
            for (xi, w) in x.iter_mut().zip(&worst_x) {
                *xi += t * (w - *xi);
            }
            x
        };
        let reflected = along(-1.0);
        let f_reflected = f(&reflected);
        evals += 1;
        if f_reflected < best {
            let expanded = along(-2.0);
            let f_expanded = f(&expanded);
            evals += 1;
            simplex[N] = if f_expanded < f_reflected {
                (expanded, f_expanded)
            } else {
                (reflected, f_reflected)
            };
        } else if f_reflected < second_worst {
            simplex[N] = (reflected, f_reflected);
        } else {
            let t = if f_reflected < worst { -0.5 } else { 0.5 };
            let contracted = along(t);
            let f_contracted = f(&contracted);
            evals += 1;
            if f_contracted < f_reflected.min(worst) {
                simplex[N] = (contracted, f_contracted);
            } else {
                let best_x = simplex[0].0;
                for (x, fx) in &mut simplex[1..] {
                    for (xi, b) in x.iter_mut().zip(&best_x) {
                        *xi = b + 0.5 * (*xi - b);
                    }
                    *fx = f(x);
                }
                evals += N;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_shifted_quadratic() {
        let f = |x: &[f64; 2]| (x[0] - 1.5).powi(2) + 10.0 * (x[1] + 0.5).powi(2) + 3.0;
        let (x, fx) = nelder_mead(f, [0.0, 0.0], [0.1, 0.1], 2000);
        assert!(
            (x[0] - 1.5).abs() < 1e-4 && (x[1] + 0.5).abs() < 1e-4,
            "{x:?}"
        );
        assert!((fx - 3.0).abs() < 1e-9);
    }

    #[test]
    fn minimises_a_non_smooth_max() {
        let f = |x: &[f64; 2]| (x[0] - 2.0).abs().max((x[1] - 1.0).abs());
        let (x, fx) = nelder_mead(f, [0.0, 0.0], [0.5, 0.5], 4000);
        assert!(fx < 1e-6, "{x:?} {fx}");
    }
}
