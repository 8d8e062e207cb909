//! What the measuring examples share: their options and their percentiles.

/// The value after `name` among `args`, parsed (`default` when `name` is not given).
pub fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> Result<T, String> {
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => (args.get(i + 1))
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("{name}: expected a value")),
    }
}

/// The `p` quantile (0 to 1) of `sorted` (not empty), nearest rank.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}
