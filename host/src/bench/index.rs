//! `index.html` of a benchmark: the summary's tables and the plots, and every problem with a
//! 3D page (`views/NAME.html`) showing the plan of the first selected planner that solved it,
//! or the problem alone. The pages share one script with three.js and the meshes
//! (`views/assets.js`), so each holds only its scene.

use std::collections::HashMap;
use std::fmt::Write;
use std::path::{Path, PathBuf};

use pulldown_cmark::{html, Options, Parser};

use crate::format::SolutionFile;
use crate::load;
use crate::suite::SuiteEntry;
use crate::validate::Report;
use crate::view::{self, Assets};

use super::error::Error;
use super::results::Row;

pub const INDEX_FILE: &str = "index.html";
const VIEWS_DIR: &str = "views";
const ASSETS_FILE: &str = "assets.js";
pub const SOLUTIONS_DIR: &str = "solutions";

/// Where the solution of a solved run is kept.
pub fn solution_path(out_dir: &Path, planner: &str, problem: &str) -> PathBuf {
    out_dir
        .join(SOLUTIONS_DIR)
        .join(planner)
        .join(format!("{problem}.json"))
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Writes the views and `index.html`; returns the index's path.
pub fn write_index(
    out_dir: &Path,
    suite_dir: &Path,
    problems: &[&SuiteEntry],
    planners: &[String],
    rows: &[Row],
    summary_md: &str,
    plots: &[PathBuf],
) -> Result<PathBuf, Error> {
    let views = out_dir.join(VIEWS_DIR);
    std::fs::create_dir_all(&views).map_err(io(&views))?;
    let assets = views.join(ASSETS_FILE);
    view::write_assets(&assets).map_err(|e| Error::Options(e.to_string()))?;
    let by_run: HashMap<(&str, &str), &Row> = rows.iter().map(|r| (r.key(), r)).collect();

    let mut body = String::new();
    let mut options = Options::empty();
    options.insert(Options::ENABLE_TABLES);
    html::push_html(&mut body, Parser::new_ext(summary_md, options));
    let _ = writeln!(body, "<h2>Plots</h2>");
    for png in plots
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
    {
        let name = png
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let svg = name.replace(".png", ".svg");
        let _ = writeln!(
            body,
            "<a href=\"{}\"><img src=\"{}\" width=\"600\" alt=\"{}\"></a>",
            escape(&svg),
            escape(&name),
            escape(&name)
        );
    }
    let _ = writeln!(body, "<h2>Problems</h2>\n<p>Each view shows the plan of the first planner \
        (in this order) that solved the problem, or the problem alone.</p>\n<table>\n<tr><th>problem</th>\
        <th>family</th><th>arms</th><th>H</th>");
    for p in planners {
        let _ = write!(body, "<th>{}</th>", escape(p));
    }
    let _ = writeln!(body, "<th>3D view</th></tr>");
    for entry in problems {
        let _ = write!(
            body,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
            escape(&entry.name),
            escape(&entry.family),
            entry.robots,
            entry.horizon
        );
        for p in planners {
            let cell = match by_run.get(&(entry.name.as_str(), p.as_str())) {
                Some(r) if r.success => format!("✓ {:.1} ms", 1000.0 * r.time_s),
                Some(r) => escape(&r.status),
                None => "-".to_string(),
            };
            let _ = write!(body, "<td>{cell}</td>");
        }
        let shown = planners.iter().find(|p| {
            by_run
                .get(&(entry.name.as_str(), p.as_str()))
                .is_some_and(|r| r.success)
        });
        let file = format!("{}.html", entry.name);
        let link = match write_view(
            out_dir,
            suite_dir,
            entry,
            shown.map(|p| p.as_str()),
            &views.join(&file),
        ) {
            Ok(()) => format!(
                "<a href=\"{VIEWS_DIR}/{}\">{}</a>",
                escape(&file),
                shown.map_or("problem".to_string(), |p| escape(p))
            ),
            Err(e) => format!("no view: {}", escape(&e)),
        };
        let _ = writeln!(body, "<td>{link}</td></tr>");
    }
    let _ = writeln!(body, "</table>");
    let page = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>omcbsa benchmark</title>\n\
         <style>body{{font:14px/1.4 system-ui,sans-serif;margin:24px}}table{{border-collapse:collapse}}\
         td,th{{border:1px solid #ccd;padding:2px 8px;text-align:right}}td:first-child{{text-align:left}}</style>\n\
         </head><body>\n{body}</body></html>\n"
    );
    let index = out_dir.join(INDEX_FILE);
    std::fs::write(&index, page).map_err(io(&index))?;
    Ok(index)
}

/// The view of one problem with `planner`'s solution (a success: validated by the runner).
fn write_view(
    out_dir: &Path,
    suite_dir: &Path,
    entry: &SuiteEntry,
    planner: Option<&str>,
    page: &Path,
) -> Result<(), String> {
    let problem = load::read_text(&suite_dir.join(&entry.file))
        .and_then(|t| load::parse_problem(&t))
        .map_err(|e| e.to_string())?;
    let solution: Option<SolutionFile> = match planner {
        Some(p) => {
            let path = solution_path(out_dir, p, &entry.name);
            let text = load::read_text(&path).map_err(|e| e.to_string())?;
            Some(load::parse_solution(&text).map_err(|e| format!("{}: {e}", path.display()))?)
        }
        None => None,
    };
    // A success passed the runner's validation: an empty report.
    let valid = Report::default();
    let text = view::html(
        &problem,
        solution.as_ref(),
        solution.as_ref().map(|_| &valid),
        Assets::Shared(ASSETS_FILE),
    )
    .map_err(|e| e.to_string())?;
    std::fs::write(page, text).map_err(|e| format!("{}: {e}", page.display()))
}
