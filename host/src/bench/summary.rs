//! Aggregates of the runs: success rate, planning times (median, mean, standard deviation,
//! extremes) and path quality per planner and number of arms, and success and time per
//! planner and motion family, as markdown tables.

use std::collections::BTreeMap;
use std::fmt::Write;

use super::quality::PathQuality;
use super::results::Row;
use crate::suite::Family;

/// Mean, sample standard deviation (n - 1; 0 for one value), smallest and largest of some
/// values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// How many values.
    pub n: usize,
    /// Their mean.
    pub mean: f64,
    /// Their sample standard deviation.
    pub std_dev: f64,
    /// The smallest.
    pub min: f64,
    /// The largest.
    pub max: f64,
}

impl Spread {
    /// Every figure times `k` (a change of unit).
    pub fn scaled(self, k: f64) -> Spread {
        Spread {
            n: self.n,
            mean: k * self.mean,
            std_dev: k * self.std_dev,
            min: k * self.min,
            max: k * self.max,
        }
    }

    /// `None` for no values.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Spread> {
        let values: Vec<f64> = values.into_iter().collect();
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let square_sum: f64 = values.iter().map(|v| (v - mean).powi(2)).sum();
        Some(Spread {
            n,
            mean,
            std_dev: if n > 1 {
                (square_sum / (n - 1) as f64).sqrt()
            } else {
                0.0
            },
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        })
    }
}

/// One planner over one group of problems (one arm count, or all).
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    /// Runs.
    pub runs: usize,
    /// Successful runs (solved and valid).
    pub successes: usize,
    /// Runs and successes on problems known to be solvable.
    pub solvable_runs: usize,
    /// Successes among `solvable_runs`.
    pub solvable_successes: usize,
    /// Planning times of the successful runs, seconds, sorted.
    pub times: Vec<f64>,
    /// Path quality of the successful runs that have it.
    pub quality: Vec<PathQuality>,
}

impl Cell {
    fn new(rows: &[&Row]) -> Cell {
        let solvable: Vec<_> = rows.iter().filter(|r| r.known_solvable).collect();
        let mut times: Vec<f64> = rows
            .iter()
            .filter(|r| r.success)
            .map(|r| r.time_s)
            .collect();
        times.sort_by(f64::total_cmp);
        Cell {
            runs: rows.len(),
            successes: rows.iter().filter(|r| r.success).count(),
            solvable_runs: solvable.len(),
            solvable_successes: solvable.iter().filter(|r| r.success).count(),
            times,
            quality: rows
                .iter()
                .filter(|r| r.success)
                .filter_map(|r| quality(r))
                .collect(),
        }
    }

    /// Mean, σ, min and max of the successful runs' planning times (seconds).
    pub fn time_spread(&self) -> Option<Spread> {
        Spread::of(self.times.iter().copied())
    }

    /// The spread of one path-quality figure over the successful runs where it applies.
    pub fn quality_spread(&self, figure: impl Fn(&PathQuality) -> Option<f64>) -> Option<Spread> {
        Spread::of(self.quality.iter().filter_map(figure))
    }

    /// Successes over runs, 0 without runs.
    pub fn success_rate(&self) -> f64 {
        ratio(self.successes, self.runs)
    }

    /// Successes over runs on problems known to be solvable (0 without such runs).
    pub fn solvable_success_rate(&self) -> f64 {
        ratio(self.solvable_successes, self.solvable_runs)
    }

    /// Median planning time of the successful runs, s.
    pub fn median(&self) -> Option<f64> {
        let n = self.times.len();
        match n {
            0 => None,
            _ if n % 2 == 1 => Some(self.times[n / 2]),
            _ => Some(0.5 * (self.times[n / 2 - 1] + self.times[n / 2])),
        }
    }

    /// Mean planning time of the successful runs, s.
    pub fn mean(&self) -> Option<f64> {
        (!self.times.is_empty()).then(|| self.times.iter().sum::<f64>() / self.times.len() as f64)
    }
}

/// A row's path quality, when it has one.
fn quality(r: &Row) -> Option<PathQuality> {
    Some(PathQuality {
        path_length_rad: r.path_length_rad?,
        max_speed_frac: r.max_speed_frac?,
        max_accel_frac: r.max_accel_frac,
        min_arm_clearance_m: r.min_arm_clearance_m,
        min_obstacle_clearance_m: r.min_obstacle_clearance_m,
        path_cost: r.path_cost?,
    })
}

fn pct(x: f64) -> String {
    format!("{:.1} %", 100.0 * x)
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

/// Every planner's cells: per arm count, per family, and over all problems.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Planners in display order.
    pub planners: Vec<String>,
    /// Arm counts present, ascending.
    pub robot_counts: Vec<usize>,
    /// Families present: the suite's in its order, then any others by name.
    pub families: Vec<String>,
    /// `(planner, Some(arms))` or `(planner, None)` for all problems.
    pub cells: BTreeMap<(String, Option<usize>), Cell>,
    /// `(planner, family)`.
    pub family_cells: BTreeMap<(String, String), Cell>,
    /// Runs whose planner reported success with a solution the validator refuses.
    pub invalid: Vec<Row>,
}

impl Summary {
    /// Groups `rows`; planners listed in `order` come first, others after in order of
    /// appearance.
    pub fn new(rows: &[Row], order: &[String]) -> Summary {
        let mut planners: Vec<String> = order
            .iter()
            .filter(|p| rows.iter().any(|r| &r.planner == *p))
            .cloned()
            .collect();
        for r in rows {
            if !planners.contains(&r.planner) {
                planners.push(r.planner.clone());
            }
        }
        let mut robot_counts: Vec<usize> = rows.iter().map(|r| r.robots).collect();
        robot_counts.sort_unstable();
        robot_counts.dedup();
        let suite_order = |f: &String| {
            let known = Family::ALL.iter().position(|k| k.name() == f);
            (known.unwrap_or(Family::ALL.len()), f.clone())
        };
        let mut families: Vec<String> = rows.iter().map(|r| r.family.clone()).collect();
        families.sort_by_key(suite_order);
        families.dedup();
        let mut cells = BTreeMap::new();
        let mut family_cells = BTreeMap::new();
        for p in &planners {
            let mine: Vec<&Row> = rows.iter().filter(|r| &r.planner == p).collect();
            for &n in &robot_counts {
                let group: Vec<&Row> = mine.iter().copied().filter(|r| r.robots == n).collect();
                cells.insert((p.clone(), Some(n)), Cell::new(&group));
            }
            for f in &families {
                let group: Vec<&Row> = mine.iter().copied().filter(|r| &r.family == f).collect();
                family_cells.insert((p.clone(), f.clone()), Cell::new(&group));
            }
            cells.insert((p.clone(), None), Cell::new(&mine));
        }
        let invalid = rows
            .iter()
            .filter(|r| r.valid == Some(false))
            .cloned()
            .collect();
        Summary {
            planners,
            robot_counts,
            families,
            cells,
            family_cells,
            invalid,
        }
    }

    /// Each planner's cells, per arm count then over all problems, with their label.
    fn groups<'a>(&'a self, planner: &str) -> impl Iterator<Item = (String, &'a Cell)> + 'a {
        let planner = planner.to_string();
        (self.robot_counts.iter().map(|&n| (n.to_string(), Some(n))))
            .chain([("all".to_string(), None)])
            .filter_map(move |(label, key)| Some((label, self.cell(&planner, key)?)))
    }

    fn time_table(&self, s: &mut String) {
        let _ = writeln!(s, "\n## Planning time of successful runs (ms)\n");
        let _ = writeln!(
            s,
            "| planner | arms | solved | mean | σ | min | median | max |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|");
        for p in &self.planners {
            for (label, c) in self.groups(p) {
                let _ = write!(s, "| {p} | {label} | {} |", c.successes);
                match c.time_spread() {
                    Some(t) => {
                        let ms = |x: f64| format!("{:.1}", 1000.0 * x);
                        let median = c.median().map_or("-".to_string(), ms);
                        let _ = writeln!(
                            s,
                            " {} | {} | {} | {median} | {} |",
                            ms(t.mean),
                            ms(t.std_dev),
                            ms(t.min),
                            ms(t.max)
                        );
                    }
                    None => {
                        let _ = writeln!(s, " - | - | - | - | - |");
                    }
                }
            }
        }
    }

    fn quality_table(&self, s: &mut String) {
        let _ = writeln!(s, "\n## Path quality of successful runs\n");
        let _ = writeln!(
            s,
            "Over each planner's own successes (so planners are compared on different problem \
             sets). Path length: joint-space length summed over the arms (rad). Cost: Ω-A*'s \
             `g` summed over the tracking arms. Speed and acceleration: the largest joint \
             speed and acceleration (finite differences at the steps) as a fraction of the \
             joint's limit. Clearances: the smallest capsule distance at the steps, between \
             arms and between an arm and an obstacle (mm). Each figure: mean over runs, and \
             the extreme in brackets (largest fraction, smallest clearance).\n"
        );
        let _ = writeln!(
            s,
            "| planner | arms | runs | path length (rad) | cost | speed / limit | acceleration / limit | arm clearance (mm) | obstacle clearance (mm) |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|");
        let fmt = |spread: Option<Spread>, scale: f64, digits: usize, extreme: Option<bool>| {
            spread.map_or("-".to_string(), |v| match extreme {
                None => format!("{:.digits$}", scale * v.mean),
                Some(max) => format!(
                    "{:.digits$} ({:.digits$})",
                    scale * v.mean,
                    scale * if max { v.max } else { v.min }
                ),
            })
        };
        for p in &self.planners {
            for (label, c) in self.groups(p) {
                let _ = writeln!(
                    s,
                    "| {p} | {label} | {} | {} | {} | {} | {} | {} | {} |",
                    c.quality.len(),
                    fmt(c.quality_spread(|q| Some(q.path_length_rad)), 1.0, 2, None),
                    fmt(c.quality_spread(|q| Some(q.path_cost)), 1.0, 2, None),
                    fmt(
                        c.quality_spread(|q| Some(q.max_speed_frac)),
                        1.0,
                        2,
                        Some(true)
                    ),
                    fmt(c.quality_spread(|q| q.max_accel_frac), 1.0, 2, Some(true)),
                    fmt(
                        c.quality_spread(|q| q.min_arm_clearance_m),
                        1000.0,
                        1,
                        Some(false)
                    ),
                    fmt(
                        c.quality_spread(|q| q.min_obstacle_clearance_m),
                        1000.0,
                        1,
                        Some(false)
                    ),
                );
            }
        }
    }

    /// The cell of `planner` on problems of `robots` arms (`None`: all problems).
    pub fn cell(&self, planner: &str, robots: Option<usize>) -> Option<&Cell> {
        self.cells.get(&(planner.to_string(), robots))
    }

    pub fn family_cell(&self, planner: &str, family: &str) -> Option<&Cell> {
        self.family_cells
            .get(&(planner.to_string(), family.to_string()))
    }

    /// Per planner and family: successes of runs, as a table with a column per family.
    fn family_table(&self, s: &mut String) {
        let _ = writeln!(s, "\n## Success rate by family\n");
        let _ = writeln!(
            s,
            "Successes of runs, per motion family (the suite's families: `omcbsa gen-bench`).\n"
        );
        let _ = write!(s, "| planner |");
        for f in &self.families {
            let _ = write!(s, " {f} |");
        }
        let _ = writeln!(
            s,
            " all |\n|---|{}---:|",
            "---:|".repeat(self.families.len())
        );
        for p in &self.planners {
            let _ = write!(s, "| {p} |");
            let cells =
                (self.families.iter().map(|f| self.family_cell(p, f))).chain([self.cell(p, None)]);
            for c in cells {
                let _ = match c {
                    Some(c) => write!(
                        s,
                        " {}/{} ({}) |",
                        c.successes,
                        c.runs,
                        pct(c.success_rate())
                    ),
                    None => write!(s, " - |"),
                };
            }
            let _ = writeln!(s);
        }
    }

    /// One row per planner and group (`label`, cell): runs, success, known solvable, times.
    fn group_table<'a>(
        &self,
        s: &mut String,
        title: &str,
        column: &str,
        groups: impl Fn(&str) -> Vec<(String, &'a Cell)>,
    ) {
        let ms = |x: Option<f64>| x.map_or("-".to_string(), |t| format!("{:.1}", 1000.0 * t));
        let _ = writeln!(s, "\n## {title}\n");
        let _ = writeln!(
            s,
            "| planner | {column} | runs | success | success (known solvable) | median (ms) | mean (ms) |"
        );
        let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|");
        for p in &self.planners {
            for (label, c) in groups(p) {
                let _ = writeln!(
                    s,
                    "| {p} | {label} | {} | {} ({}) | {} ({}/{}) | {} | {} |",
                    c.runs,
                    pct(c.success_rate()),
                    c.successes,
                    pct(c.solvable_success_rate()),
                    c.solvable_successes,
                    c.solvable_runs,
                    ms(c.median()),
                    ms(c.mean())
                );
            }
        }
    }

    /// The markdown report. `context` is a line saying what was run.
    pub fn markdown(&self, context: &str) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Benchmark results\n\n{context}\n");
        let _ = writeln!(
            s,
            "Success: solved within the timeout with a solution that passes `omcbsa validate`. \
             Times: the planners' reported planning times of successful runs, in milliseconds.\n"
        );
        let _ = writeln!(s, "## Success rate by number of arms\n");
        let mut head = "| planner |".to_string();
        let mut rule = "|---|".to_string();
        for n in &self.robot_counts {
            let _ = write!(head, " {n} arms |");
            rule.push_str("---:|");
        }
        let _ = writeln!(s, "{head} all | known solvable |\n{rule}---:|---:|");
        for p in &self.planners {
            let _ = write!(s, "| {p} |");
            for &n in &self.robot_counts {
                let c = &self.cells[&(p.clone(), Some(n))];
                let _ = write!(s, " {} |", pct(c.success_rate()));
            }
            let all = &self.cells[&(p.clone(), None)];
            let _ = writeln!(
                s,
                " {} | {} |",
                pct(all.success_rate()),
                pct(all.solvable_success_rate())
            );
        }
        self.family_table(&mut s);
        self.group_table(&mut s, "Per planner and number of arms", "arms", |p| {
            self.groups(p).collect()
        });
        self.group_table(&mut s, "Per planner and family", "family", |p| {
            (self.families.iter())
                .filter_map(|f| Some((f.clone(), self.family_cell(p, f)?)))
                .collect()
        });
        self.time_table(&mut s);
        self.quality_table(&mut s);
        if !self.invalid.is_empty() {
            let _ = writeln!(s, "\n## Invalid \"successes\" (counted as failures)\n");
            for r in &self.invalid {
                let _ = writeln!(s, "- {} on {}: {}", r.planner, r.problem, r.message);
            }
        }
        s
    }
}
