//! The model-error map as a figure and a table: short vs finite film over `B/D × ε`,
//! banded at 1 %, 5 % and 20 % (docs/finite-film.md "Model-error map").

use plotters::prelude::*;
use rayon::prelude::*;

use super::{compute_short_model_error, FiniteSettings};

/// Error levels the map is banded at (relative load error; attitude error in radians,
/// i.e. the load component normal to the true load over its magnitude).
pub const MAP_LEVELS: [f64; 3] = [0.01, 0.05, 0.20];

/// Short-vs-finite errors on a `B/D × ε` grid.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorMap {
    /// `B/D` values (rows).
    pub aspects: Vec<f64>,
    /// Eccentricity ratios (columns).
    pub eccs: Vec<f64>,
    /// `|W_short|/|W_finite| − 1` per row and column.
    pub load: Vec<Vec<f64>>,
    /// Attitude angle short − finite, degrees, per row and column.
    pub attitude_deg: Vec<Vec<f64>>,
}

/// Computes the map on `settings` (cells in parallel on rayon's pool).
pub fn compute_error_map(aspects: &[f64], eccs: &[f64], settings: &FiniteSettings) -> ErrorMap {
    let cells: Vec<(f64, f64)> = aspects
        .par_iter()
        .flat_map_iter(|&bd| eccs.iter().map(move |&e| (bd, e)))
        .map(|(bd, e)| {
            let r = compute_short_model_error(bd, e, settings);
            (r.load, r.attitude_deg)
        })
        .collect();
    let n = eccs.len();
    ErrorMap {
        aspects: aspects.to_vec(),
        eccs: eccs.to_vec(),
        load: cells
            .chunks(n)
            .map(|c| c.iter().map(|v| v.0).collect())
            .collect(),
        attitude_deg: cells
            .chunks(n)
            .map(|c| c.iter().map(|v| v.1).collect())
            .collect(),
    }
}

/// Band index of an error magnitude: 0 below 1 %, 1 up to 5 %, 2 up to 20 %, 3 above.
fn band(v: f64) -> usize {
    MAP_LEVELS.iter().filter(|&&l| v.abs() >= l).count()
}

const BAND_COLOURS: [RGBColor; 4] = [
    RGBColor(220, 240, 220),
    RGBColor(250, 235, 170),
    RGBColor(245, 170, 110),
    RGBColor(205, 80, 80),
];
const BAND_NAMES: [&str; 4] = ["< 1 %", "1-5 %", "5-20 %", "> 20 %"];

/// A map cell's banded value by (row, column).
type CellValue<'a> = Box<dyn Fn(usize, usize) -> f64 + 'a>;

/// Two banded panels (load magnitude, attitude) as one SVG, 1200 × 560 px.
pub fn error_map_svg(map: &ErrorMap) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (left, right) = root.split_horizontally(600);
        let edges = |v: &[f64], k: usize| -> (f64, f64) {
            let lo = if k == 0 {
                v[0]
            } else {
                0.5 * (v[k - 1] + v[k])
            };
            let hi = if k + 1 == v.len() {
                v[k]
            } else {
                0.5 * (v[k] + v[k + 1])
            };
            (lo, hi)
        };
        let panels: [(&DrawingArea<_, _>, &str, CellValue); 2] = [
            (
                &left,
                "load magnitude |W_short|/|W_finite| - 1",
                Box::new(|i, j| map.load[i][j]),
            ),
            (
                &right,
                "attitude angle error (rad = relative normal load)",
                Box::new(|i, j| map.attitude_deg[i][j].to_radians()),
            ),
        ];
        for (area, title, value) in panels {
            let mut chart = ChartBuilder::on(area)
                .caption(title, ("sans-serif", 16))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .build_cartesian_2d(
                    map.aspects[0]..map.aspects[map.aspects.len() - 1],
                    map.eccs[0]..map.eccs[map.eccs.len() - 1],
                )
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc("B/D")
                .y_desc("eccentricity ratio")
                .disable_mesh()
                .draw()
                .map_err(|e| e.to_string())?;
            let mut cells = Vec::new();
            for i in 0..map.aspects.len() {
                for j in 0..map.eccs.len() {
                    let (x0, x1) = edges(&map.aspects, i);
                    let (y0, y1) = edges(&map.eccs, j);
                    cells.push(Rectangle::new(
                        [(x0, y0), (x1, y1)],
                        BAND_COLOURS[band(value(i, j))].filled(),
                    ));
                }
            }
            chart.draw_series(cells).map_err(|e| e.to_string())?;
            for (b, name) in BAND_NAMES.iter().enumerate() {
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(0.0, 0.0), (0.0, 0.0)],
                        BAND_COLOURS[b].filled(),
                    )))
                    .map_err(|e| e.to_string())?
                    .label(*name)
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 10, y + 5)], BAND_COLOURS[b].filled())
                    });
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

/// Markdown table: one row per `B/D`, cells `load % / attitude °`.
pub fn error_map_markdown(map: &ErrorMap) -> String {
    let mut s = String::from("| B/D \\ ε |");
    for e in &map.eccs {
        s += &format!(" {e} |");
    }
    s += "\n|---|";
    for _ in &map.eccs {
        s += "---|";
    }
    s += "\n";
    for (i, bd) in map.aspects.iter().enumerate() {
        s += &format!("| {bd} |");
        for j in 0..map.eccs.len() {
            s += &format!(
                " {:+.1} % / {:+.2}° |",
                100.0 * map.load[i][j],
                map.attitude_deg[i][j]
            );
        }
        s += "\n";
    }
    s
}
