//! The benchmark's figures, in SVG and PNG (plotters): success rate per planner, success rate
//! by number of arms and by motion family, and the distribution of planning times (share of runs solved within a
//! time budget, the cumulative distribution of successful planning times), the mean planning
//! time with its standard deviation, and the mean joint-space path length, per planner and
//! number of arms.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::summary::{Cell, Spread, Summary};

const SIZE: (u32, u32) = (900, 540);
/// Fonts tried when `fc-match` finds none (Debian's fonts-dejavu-core).
const FALLBACK_FONTS: [&str; 2] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

/// The figures, by file name.
const CHARTS: [&str; 6] = [
    "success_overall",
    "success_by_robots",
    "success_by_family",
    "runtime_cdf",
    "runtime_mean",
    "path_length",
];

/// Writes every chart of [`CHARTS`] as `.svg` and `.png` into `dir`; returns the files
/// written. `timeout_s` bounds the time axis.
pub fn write_all(dir: &Path, summary: &Summary, timeout_s: f64) -> Result<Vec<PathBuf>, String> {
    register_font()?;
    let mut written = Vec::new();
    for name in CHARTS {
        let svg = dir.join(format!("{name}.svg"));
        {
            let root = SVGBackend::new(&svg, SIZE).into_drawing_area();
            draw(name, &root, summary, timeout_s)?;
            root.present()
                .map_err(|e| format!("{}: {e}", svg.display()))?;
        }
        let png = dir.join(format!("{name}.png"));
        {
            let root = BitMapBackend::new(&png, SIZE).into_drawing_area();
            draw(name, &root, summary, timeout_s)?;
            root.present()
                .map_err(|e| format!("{}: {e}", png.display()))?;
        }
        written.extend([svg, png]);
    }
    Ok(written)
}

fn draw<DB: DrawingBackend>(
    name: &str,
    root: &DrawingArea<DB, Shift>,
    s: &Summary,
    timeout_s: f64,
) -> Result<(), String> {
    match name {
        "success_overall" => success_overall(root, s),
        "success_by_robots" => success_by_robots(root, s),
        "success_by_family" => success_by_family(root, s),
        "runtime_mean" => grouped_bars(
            root,
            s,
            "Mean planning time of successful runs (bars: ±σ)",
            "planning time (ms, log scale)",
            &|c| c.time_spread().map(|t| t.scaled(1000.0)),
        ),
        "path_length" => grouped_bars(
            root,
            s,
            "Mean joint-space path length of successful runs (bars: ±σ)",
            "path length, all arms (rad, log scale)",
            &|c| c.quality_spread(|q| Some(q.path_length_rad)),
        ),
        _ => runtime_cdf(root, s, timeout_s),
    }
}

/// Bitmap and SVG text both need the font's metrics: plotters is built with ab_glyph (no
/// system font library), so one TrueType font is read once and registered.
fn register_font() -> Result<(), String> {
    static FONT: OnceLock<Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let path = font_path().ok_or_else(|| {
            "no TrueType sans-serif font found (fc-match and the DejaVu paths gave none; install \
             fonts-dejavu-core) so no plots were drawn"
                .to_string()
        })?;
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        // plotters keeps registered fonts for the life of the program.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{}: not a usable TrueType font", path.display()))
    })
    .clone()
}

fn font_path() -> Option<PathBuf> {
    let fc = std::process::Command::new("fc-match")
        .args(["--format=%{file}", "sans-serif:style=Regular"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
    let truetype = |p: &PathBuf| {
        p.is_file()
            && p.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("ttf") || e.eq_ignore_ascii_case("otf"))
    };
    fc.into_iter()
        .chain(FALLBACK_FONTS.iter().map(PathBuf::from))
        .find(truetype)
}

fn color(i: usize) -> RGBColor {
    let c = Palette99::pick(i).to_rgba();
    RGBColor(c.0, c.1, c.2)
}

/// The series legend, the same on every plot.
fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    at: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(at)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(err)
}

fn err(e: impl std::fmt::Display) -> String {
    format!("drawing a plot: {e}")
}

fn success_overall<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &Summary,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let n = s.planners.len();
    let mut chart = ChartBuilder::on(root)
        .caption("Success rate per planner", ("sans-serif", 26))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d((0..n.saturating_sub(1)).into_segmented(), 0.0..105.0)
        .map_err(err)?;
    let labels = s.planners.clone();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .y_desc("success (%)")
        .y_label_formatter(&|y| format!("{y:.0}"))
        .x_label_formatter(&|v| match v {
            SegmentValue::CenterOf(i) => labels.get(*i).cloned().unwrap_or_default(),
            _ => String::new(),
        })
        .label_style(("sans-serif", 16))
        .draw()
        .map_err(err)?;
    let rates: Vec<f64> = (s.planners.iter())
        .map(|p| 100.0 * s.cell(p, None).map_or(0.0, |c| c.success_rate()))
        .collect();
    chart
        .draw_series(rates.iter().enumerate().map(|(i, &r)| {
            let mut bar = Rectangle::new(
                [
                    (SegmentValue::Exact(i), 0.0),
                    (SegmentValue::Exact(i + 1), r),
                ],
                color(i).filled(),
            );
            bar.set_margin(0, 0, 18, 18);
            bar
        }))
        .map_err(err)?;
    chart
        .draw_series(rates.iter().enumerate().map(|(i, &r)| {
            Text::new(
                format!("{r:.1} %"),
                (SegmentValue::CenterOf(i), r + 4.0),
                ("sans-serif", 15).into_font(),
            )
        }))
        .map_err(err)?;
    Ok(())
}

fn success_by_robots<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &Summary,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let lo = s.robot_counts.first().copied().unwrap_or(2) as f64;
    let hi = s.robot_counts.last().copied().unwrap_or(6) as f64;
    let mut chart = ChartBuilder::on(root)
        .caption("Success rate by number of arms", ("sans-serif", 26))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d((lo - 0.3)..(hi + 0.3), 0.0..105.0)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("arms")
        .y_desc("success (%)")
        .y_label_formatter(&|y| format!("{y:.0}"))
        .x_labels(s.robot_counts.len().max(2))
        .x_label_formatter(&|x| format!("{x:.0}"))
        .label_style(("sans-serif", 16))
        .draw()
        .map_err(err)?;
    for (i, p) in s.planners.iter().enumerate() {
        let points: Vec<(f64, f64)> = (s.robot_counts.iter())
            .filter_map(|&n| {
                s.cell(p, Some(n))
                    .map(|c| (n as f64, 100.0 * c.success_rate()))
            })
            .collect();
        let c = color(i);
        chart
            .draw_series(LineSeries::new(points.clone(), c.stroke_width(3)))
            .map_err(err)?
            .label(p.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(3)));
        chart
            .draw_series(points.into_iter().map(|pt| Circle::new(pt, 5, c.filled())))
            .map_err(err)?;
    }
    legend(&mut chart, SeriesLabelPosition::LowerLeft)
}

/// One group of bars per family, one bar per planner: its success rate there.
fn success_by_family<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &Summary,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let groups = s.families.len().max(1);
    let width = 0.8 / s.planners.len().max(1) as f64;
    let mut chart = ChartBuilder::on(root)
        .caption("Success rate by motion family", ("sans-serif", 26))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        // Room above the bars for the legend.
        .build_cartesian_2d(-0.5..(groups as f64 - 0.5), 0.0..140.0)
        .map_err(err)?;
    let families = s.families.clone();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .y_desc("success (%)")
        .y_labels(8)
        .y_label_formatter(&|y| {
            if *y <= 100.0 {
                format!("{y:.0}")
            } else {
                String::new()
            }
        })
        .x_labels(groups)
        .x_label_formatter(&|x| {
            let g = x.round();
            let at_group = (x - g).abs() < 1e-6 && g >= 0.0;
            (families.get(g as usize).filter(|_| at_group)).map_or(String::new(), |f| f.clone())
        })
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    for (i, p) in s.planners.iter().enumerate() {
        let c = color(i);
        let x = |g: usize| g as f64 + (i as f64 - (s.planners.len() as f64 - 1.0) / 2.0) * width;
        let bars = (s.families.iter().enumerate()).filter_map(|(g, f)| {
            let rate = 100.0 * s.family_cell(p, f)?.success_rate();
            Some(Rectangle::new(
                [(x(g) - 0.45 * width, 0.0), (x(g) + 0.45 * width, rate)],
                c.filled(),
            ))
        });
        chart
            .draw_series(bars)
            .map_err(err)?
            .label(p.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 18, y + 6)], c.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)
}

fn runtime_cdf<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &Summary,
    timeout_s: f64,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let fastest = (s.cells.values())
        .flat_map(|c| c.times.first().copied())
        .fold(f64::INFINITY, f64::min);
    let lo = if fastest.is_finite() {
        (fastest * 0.8).max(1e-5)
    } else {
        1e-3
    };
    let hi = timeout_s.max(lo * 10.0);
    let mut chart = ChartBuilder::on(root)
        .caption(
            "Planning time: share of runs solved within t",
            ("sans-serif", 26),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d((lo..hi).log_scale(), 0.0..105.0)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("planning time t (s, log scale)")
        .y_desc("solved within t (%)")
        .y_label_formatter(&|y| format!("{y:.0}"))
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .label_style(("sans-serif", 16))
        .draw()
        .map_err(err)?;
    for (i, p) in s.planners.iter().enumerate() {
        let Some(cell) = s.cell(p, None) else {
            continue;
        };
        let runs = cell.runs.max(1) as f64;
        // A step curve: flat until each success time, then one run higher.
        let mut points = vec![(lo, 0.0)];
        for (k, &t) in cell.times.iter().enumerate() {
            let t = t.clamp(lo, hi);
            points.push((t, 100.0 * k as f64 / runs));
            points.push((t, 100.0 * (k + 1) as f64 / runs));
        }
        points.push((hi, 100.0 * cell.times.len() as f64 / runs));
        let c = color(i);
        chart
            .draw_series(LineSeries::new(points, c.stroke_width(3)))
            .map_err(err)?
            .label(p.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(3)));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft)
}

/// One group of bars per arm count, one bar per planner at its mean with a ±σ error bar, on a
/// log scale (means span several decades); the lower whisker stops at the axis.
fn grouped_bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &Summary,
    caption: &str,
    y_desc: &str,
    value: &dyn Fn(&Cell) -> Option<Spread>,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let spreads: Vec<(usize, usize, Spread)> = (s.planners.iter().enumerate())
        .flat_map(|(i, p)| {
            (s.robot_counts.iter().enumerate())
                .filter_map(move |(g, &n)| s.cell(p, Some(n)).and_then(value).map(|v| (g, i, v)))
        })
        .collect();
    let positive = spreads.iter().map(|(_, _, v)| v.min).filter(|m| *m > 0.0);
    let lo = positive.fold(f64::INFINITY, f64::min);
    let lo = if lo.is_finite() { lo * 0.5 } else { 1e-3 };
    let hi = (spreads.iter())
        .map(|(_, _, v)| v.mean + v.std_dev)
        .fold(lo * 10.0, f64::max)
        * 2.0;
    let groups = s.robot_counts.len().max(1);
    let width = 0.8 / s.planners.len().max(1) as f64;
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5..(groups as f64 - 0.5), (lo..hi).log_scale())
        .map_err(err)?;
    let counts = s.robot_counts.clone();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_desc("arms")
        .y_desc(y_desc)
        .x_labels(groups)
        .x_label_formatter(&|x| {
            let g = x.round();
            if (x - g).abs() < 1e-6 && g >= 0.0 {
                counts
                    .get(g as usize)
                    .map_or(String::new(), |n| n.to_string())
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|y| format!("{y:.1e}"))
        .label_style(("sans-serif", 16))
        .draw()
        .map_err(err)?;
    let centre =
        |g: usize, i: usize| g as f64 + (i as f64 - (s.planners.len() as f64 - 1.0) / 2.0) * width;
    for (i, p) in s.planners.iter().enumerate() {
        let c = color(i);
        let mine: Vec<&(usize, usize, Spread)> = spreads.iter().filter(|x| x.1 == i).collect();
        chart
            .draw_series(mine.iter().map(|&&(g, i, v)| {
                let x = centre(g, i);
                Rectangle::new(
                    [(x - 0.45 * width, lo), (x + 0.45 * width, v.mean.max(lo))],
                    c.filled(),
                )
            }))
            .map_err(err)?
            .label(p.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 18, y + 6)], c.filled()));
        chart
            .draw_series(mine.iter().map(|&&(g, i, v)| {
                ErrorBar::new_vertical(
                    centre(g, i),
                    (v.mean - v.std_dev).max(lo),
                    v.mean.max(lo),
                    (v.mean + v.std_dev).max(lo),
                    BLACK.stroke_width(2),
                    8,
                )
            }))
            .map_err(err)?;
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft)
}
