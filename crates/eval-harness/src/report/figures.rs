//! The paper's figures as hand-written SVG (no script): mean generated tokens per task and
//! mean images and observations shown to a model per task (Figure 2's two panels), one bar per
//! benchmark under each condition; failure attribution as stacked bars (Figures 3 and 5).
//! Every mean goes through [`crate::stats::mean`].

use std::fmt::Write;

use super::ReportError;
use super::html::escape;
use super::load::Record;
use super::metrics;
use super::study::{Run, Study};
use super::tables::{ATTRIBUTION_NAMES, attribution_shares};
use crate::stats;

/// One figure: its file name, title, caption, and SVG text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Figure {
    /// The file name, e.g. `tokens.svg`.
    pub name: &'static str,
    /// The title, plain text.
    pub title: String,
    /// The caption, plain text.
    pub caption: String,
    /// The whole SVG document.
    pub svg: String,
}

const WIDTH: f64 = 960.0;
/// Where bars start; benchmark names are written right-aligned before it.
const PLOT_LEFT: f64 = 250.0;
/// Room right of the longest bar for its value.
const PLOT_RIGHT: f64 = 110.0;
const BAR_ROW: f64 = 20.0;
const BAR: f64 = 14.0;
const GROUP_HEADER: f64 = 22.0;
const GROUP_GAP: f64 = 10.0;
const TOP: f64 = 78.0;

const BENCHMARK_COLOURS: [&str; 6] = ["#4e79a7", "#f28e2b", "#59a14f", "#b07aa1", "#76b7b2", "#edc948"];
/// Representation, search, grounding, goal not reached, unattributed.
const CLASS_COLOURS: [&str; 5] = ["#e15759", "#f28e2b", "#4e79a7", "#bab0ac", "#79706e"];

/// The smallest of 1, 2, 2.5, 5 × 10^k at or above `x` (1 for nothing to show).
fn nice_ceiling(x: f64) -> f64 {
    if x <= 0.0 || !x.is_finite() {
        return 1.0;
    }
    let power = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0].iter().map(|m| m * power).find(|v| *v >= x * (1.0 - 1e-12)).unwrap_or(10.0 * power)
}

fn number(value: f64) -> String {
    let text = format!("{value:.2}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" { "0".into() } else { text.to_string() }
}

/// A label cut to `max` characters (the whole in the element's `<title>`).
fn clipped(text: &str, max: usize) -> String {
    if text.chars().count() <= max { text.to_string() } else { text.chars().take(max - 1).collect::<String>() + "…" }
}

struct Group {
    label: String,
    /// (benchmark name, colour index, segments); a plain bar has one segment.
    bars: Vec<(String, usize, Vec<f64>)>,
}

/// The frame: title, axis ticks along the top, grid lines; then `body` draws the groups.
fn chart(title: &str, axis: &str, legend: &[(&str, &str)], groups: &[Group], max: f64, unit: &str, colours: &[&str]) -> String {
    let rows: usize = groups.iter().map(|g| g.bars.len()).sum();
    let height = TOP + groups.len() as f64 * (GROUP_HEADER + GROUP_GAP) + rows as f64 * BAR_ROW + 20.0;
    let plot = WIDTH - PLOT_LEFT - PLOT_RIGHT;
    let x = |value: f64| PLOT_LEFT + plot * value / max;
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{height}\" viewBox=\"0 0 {WIDTH} {height}\" \
         font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\" role=\"img\" aria-label=\"{}\">",
        escape(title)
    );
    let _ = writeln!(svg, "<title>{}</title>", escape(title));
    let _ = writeln!(svg, "<rect x=\"0\" y=\"0\" width=\"{WIDTH}\" height=\"{height}\" fill=\"#ffffff\"/>");
    let _ = writeln!(svg, "<text x=\"10\" y=\"22\" font-size=\"15\" font-weight=\"bold\">{}</text>", escape(title));
    let mut legend_x = 10.0;
    for (name, colour) in legend {
        let _ = writeln!(svg, "<rect x=\"{legend_x}\" y=\"34\" width=\"12\" height=\"12\" fill=\"{colour}\"/>");
        let _ = writeln!(svg, "<text x=\"{}\" y=\"44\">{}</text>", legend_x + 16.0, escape(name));
        legend_x += 16.0 + 7.0 * name.chars().count() as f64 + 18.0;
    }
    let _ =
        writeln!(svg, "<text x=\"{}\" y=\"{}\" text-anchor=\"end\" fill=\"#555555\">{}</text>", PLOT_LEFT - 22.0, TOP - 10.0, escape(axis));
    for i in 0..=5 {
        let value = max * f64::from(i) / 5.0;
        let _ = writeln!(
            svg,
            "<text x=\"{:.1}\" y=\"{}\" text-anchor=\"middle\" fill=\"#555555\">{}{unit}</text>",
            x(value),
            TOP - 10.0,
            number(value)
        );
    }
    let mut y = TOP;
    for group in groups {
        let _ = writeln!(
            svg,
            "<text x=\"10\" y=\"{:.1}\" font-weight=\"bold\"><title>{}</title>{}</text>",
            y + 15.0,
            escape(&group.label),
            escape(&clipped(&group.label, 120))
        );
        y += GROUP_HEADER;
        // Grid lines and the axis beside this group's bars only, clear of its header.
        let (top, bottom) = (y - 3.0, y + group.bars.len() as f64 * BAR_ROW - 3.0);
        for i in 0..=5 {
            let (at, colour) = (x(max * f64::from(i) / 5.0), if i == 0 { "#333333" } else { "#dddddd" });
            let _ = writeln!(svg, "<line x1=\"{at:.1}\" y1=\"{top:.1}\" x2=\"{at:.1}\" y2=\"{bottom:.1}\" stroke=\"{colour}\"/>");
        }
        for (benchmark, colour, segments) in &group.bars {
            let _ = writeln!(svg, "<text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>", PLOT_LEFT - 8.0, y + 11.0, escape(benchmark));
            let mut left = 0.0;
            for (k, segment) in segments.iter().enumerate() {
                let colour = colours[(colour + k) % colours.len()];
                let width = x(left + segment) - x(left);
                if width > 0.0 {
                    let _ = writeln!(
                        svg,
                        "<rect x=\"{:.1}\" y=\"{y:.1}\" width=\"{width:.1}\" height=\"{BAR}\" fill=\"{colour}\"><title>{}: {}{unit}</title></rect>",
                        x(left),
                        escape(benchmark),
                        number(*segment)
                    );
                }
                left += segment;
            }
            let _ = writeln!(svg, "<text x=\"{:.1}\" y=\"{:.1}\" fill=\"#333333\">{}{unit}</text>", x(left) + 5.0, y + 11.0, number(left));
            y += BAR_ROW;
        }
        y += GROUP_GAP;
    }
    svg.push_str("</svg>\n");
    svg
}

/// A figure with nothing to draw: the frame and a sentence saying why.
fn empty_chart(title: &str, message: &str) -> String {
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"90\" viewBox=\"0 0 {WIDTH} 90\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\">\n\
         <title>{0}</title>\n<rect x=\"0\" y=\"0\" width=\"{WIDTH}\" height=\"90\" fill=\"#ffffff\"/>\n\
         <text x=\"10\" y=\"22\" font-size=\"15\" font-weight=\"bold\">{0}</text>\n<text x=\"10\" y=\"55\" fill=\"#555555\">{1}</text>\n</svg>\n",
        escape(title),
        escape(message)
    )
}

/// The mean over runs of each run's mean of `value` over the records that hold it.
fn mean_per_task(runs: &[Run<'_>], value: fn(&Record) -> Option<f64>) -> Result<Option<f64>, ReportError> {
    let mut per_run = Vec::new();
    for run in runs {
        let values: Vec<f64> = run.records.iter().filter_map(|(_, r)| value(r)).collect();
        if !values.is_empty() {
            per_run.push(stats::mean(&values).map_err(|source| ReportError::Stats { context: "figure mean".into(), source })?);
        }
    }
    if per_run.is_empty() {
        return Ok(None);
    }
    stats::mean(&per_run).map(Some).map_err(|source| ReportError::Stats { context: "figure mean over runs".into(), source })
}

fn mean_bars(
    study: &Study<'_>,
    name: &'static str,
    title: &str,
    caption: &str,
    what: &str,
    value: fn(&Record) -> Option<f64>,
) -> Result<Figure, ReportError> {
    let mut groups = Vec::new();
    for (c, condition) in study.conditions.iter().enumerate() {
        let mut bars = Vec::new();
        for (b, benchmark) in study.benchmarks.iter().enumerate() {
            if let Some(mean) = mean_per_task(study.runs(c, b), value)? {
                bars.push((benchmark.clone(), b, vec![mean]));
            }
        }
        if !bars.is_empty() {
            groups.push(Group { label: condition.label(), bars });
        }
    }
    let svg = if groups.is_empty() {
        empty_chart(title, &format!("No records carry {what}."))
    } else {
        let max = groups.iter().flat_map(|g| &g.bars).map(|(_, _, s)| s[0]).fold(0.0, f64::max);
        let legend: Vec<(&str, &str)> =
            study.benchmarks.iter().enumerate().map(|(b, n)| (n.as_str(), BENCHMARK_COLOURS[b % BENCHMARK_COLOURS.len()])).collect();
        chart(title, "per task", &legend, &groups, nice_ceiling(max), "", &BENCHMARK_COLOURS)
    };
    Ok(Figure { name, title: title.to_string(), caption: caption.to_string(), svg })
}

fn attribution_figure(study: &Study<'_>) -> Result<Figure, ReportError> {
    let title = "Terminal failure attribution (% of all tasks)";
    let mut groups = Vec::new();
    for (c, condition) in study.conditions.iter().enumerate() {
        let mut bars = Vec::new();
        for (b, benchmark) in study.benchmarks.iter().enumerate() {
            if let Some(shares) = attribution_shares(study.runs(c, b))? {
                bars.push((benchmark.clone(), 0, shares.classes.iter().map(|s| 100.0 * s).collect()));
            }
        }
        if !bars.is_empty() {
            groups.push(Group { label: condition.label(), bars });
        }
    }
    let svg = if groups.is_empty() {
        empty_chart(title, "No records carry a failure attribution (`attribution`).")
    } else {
        let max = groups.iter().flat_map(|g| &g.bars).map(|(_, _, s)| s.iter().sum::<f64>()).fold(0.0, f64::max);
        let mut legend: Vec<(&str, &str)> =
            ATTRIBUTION_NAMES.iter().zip(CLASS_COLOURS).map(|((_, name), colour)| (*name, colour)).collect();
        legend.push(("Unattributed", CLASS_COLOURS[4]));
        chart(title, "% of tasks", &legend, &groups, nice_ceiling(max.max(10.0)), "%", &CLASS_COLOURS)
    };
    Ok(Figure {
        name: "attribution.svg",
        title: title.into(),
        caption: "Each failed task at the earliest boundary that prevented completion, as a percentage of all tasks, per condition \
                  and benchmark (mean over runs); the bar's length is the failure rate. Successful tasks contribute to none."
            .into(),
        svg,
    })
}

/// Every figure.
pub(crate) fn figures(study: &Study<'_>) -> Result<Vec<Figure>, ReportError> {
    Ok(vec![
        mean_bars(
            study,
            "tokens.svg",
            "Mean generated tokens per task",
            "Tokens the models generated per task (Phase I and Phase II together; a direct policy's replies), mean over tasks and runs.",
            "generated tokens",
            metrics::generated_tokens,
        )?,
        mean_bars(
            study,
            "images.svg",
            "Mean model-visible images per task",
            "Images shown to a model per task, mean over tasks and runs (Phase II never sees one; the systematic explorer shows none).",
            "image counts",
            metrics::images,
        )?,
        mean_bars(
            study,
            "observations.svg",
            "Mean observations shown to a model per task",
            "Observations (text or picture) put in front of a model per task, mean over tasks and runs.",
            "observation counts",
            metrics::observations,
        )?,
        mean_bars(
            study,
            "calls.svg",
            "Mean model calls per task",
            "Calls to a model per task (Phase I chat turns and Phase II requests), mean over tasks and runs.",
            "model calls",
            metrics::model_calls,
        )?,
        attribution_figure(study)?,
    ])
}
