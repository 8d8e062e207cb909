//! Aggregates of the runs: success rate and planning times per planner and number of arms,
//! as a markdown table.

use std::collections::BTreeMap;
use std::fmt::Write;

use super::results::Row;

/// One planner over one group of problems (one arm count, or all).
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub runs: usize,
    pub successes: usize,
    /// Runs and successes on problems known to be solvable.
    pub solvable_runs: usize,
    pub solvable_successes: usize,
    /// Planning times of the successful runs, seconds, sorted.
    pub times: Vec<f64>,
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
        }
    }

    /// Successes over runs, 0 without runs.
    pub fn success_rate(&self) -> f64 {
        ratio(self.successes, self.runs)
    }

    pub fn solvable_success_rate(&self) -> f64 {
        ratio(self.solvable_successes, self.solvable_runs)
    }

    pub fn median(&self) -> Option<f64> {
        let n = self.times.len();
        match n {
            0 => None,
            _ if n % 2 == 1 => Some(self.times[n / 2]),
            _ => Some(0.5 * (self.times[n / 2 - 1] + self.times[n / 2])),
        }
    }

    pub fn mean(&self) -> Option<f64> {
        (!self.times.is_empty()).then(|| self.times.iter().sum::<f64>() / self.times.len() as f64)
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

/// Every planner's cells: per arm count, and over all problems.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Planners in display order.
    pub planners: Vec<String>,
    /// Arm counts present, ascending.
    pub robot_counts: Vec<usize>,
    /// `(planner, Some(arms))` or `(planner, None)` for all problems.
    pub cells: BTreeMap<(String, Option<usize>), Cell>,
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
        let mut cells = BTreeMap::new();
        for p in &planners {
            let mine: Vec<&Row> = rows.iter().filter(|r| &r.planner == p).collect();
            for &n in &robot_counts {
                let group: Vec<&Row> = mine.iter().copied().filter(|r| r.robots == n).collect();
                cells.insert((p.clone(), Some(n)), Cell::new(&group));
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
            cells,
            invalid,
        }
    }

    pub fn cell(&self, planner: &str, robots: Option<usize>) -> Option<&Cell> {
        self.cells.get(&(planner.to_string(), robots))
    }

    /// The markdown report. `context` is a line saying what was run.
    pub fn markdown(&self, context: &str) -> String {
        let mut s = String::new();
        let ms = |x: Option<f64>| x.map_or("-".to_string(), |t| format!("{:.1}", 1000.0 * t));
        let pct = |x: f64| format!("{:.1} %", 100.0 * x);
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
        let _ = writeln!(s, "\n## Per planner and number of arms\n");
        let _ = writeln!(s, "| planner | arms | runs | success | success (known solvable) | median (ms) | mean (ms) |");
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|");
        for p in &self.planners {
            let groups = self
                .robot_counts
                .iter()
                .map(|&n| (n.to_string(), Some(n)))
                .chain([("all".to_string(), None)]);
            for (label, key) in groups {
                let c = &self.cells[&(p.clone(), key)];
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
        if !self.invalid.is_empty() {
            let _ = writeln!(s, "\n## Invalid \"successes\" (counted as failures)\n");
            for r in &self.invalid {
                let _ = writeln!(s, "- {} on {}: {}", r.planner, r.problem, r.message);
            }
        }
        s
    }
}
