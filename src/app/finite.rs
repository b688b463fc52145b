//! `bearing-sweep finite --map DIR`: the finite-film error map (the error of the
//! short-bearing closed forms against the finite-length film over aspect ratio and
//! eccentricity) as an SVG on a fine grid and a markdown table on the reference grid.

use std::path::{Path, PathBuf};

use super::AppError;
use crate::bearing::finite as fin;

/// Smallest aspect ratio L/D of the map.
const ASPECT_MIN: f64 = 0.1;
/// Largest aspect ratio L/D of the map.
const ASPECT_MAX: f64 = 1.0;
/// Largest eccentricity ratio of the map (the film solver's range).
const ECC_MAX: f64 = 0.95;
/// Slack on the grid's end points against rounding of `k / n`.
const GRID_SLACK: f64 = 1e-9;

/// The fine grid of the SVG for `resolution` points per unit (at least 2): aspect ratios
/// from 0.1 to 1 and eccentricities from 0 to 0.95, both in steps of 1 / resolution.
pub fn error_map_grid(resolution: usize) -> (Vec<f64>, Vec<f64>) {
    let n = resolution.max(2);
    let steps = |span: f64| (span * n as f64 + GRID_SLACK).floor() as usize;
    let aspects: Vec<f64> = (0..=steps(ASPECT_MAX - ASPECT_MIN))
        .map(|k| ASPECT_MIN + k as f64 / n as f64)
        .filter(|&v| v <= ASPECT_MAX + GRID_SLACK)
        .collect();
    let eccs: Vec<f64> = (0..=steps(ECC_MAX)).map(|k| k as f64 / n as f64).collect();
    (aspects, eccs)
}

/// Computes the error map, writes `finite-error-map.svg` (fine grid) and
/// `finite-error-map.md` (reference grid) into `dir` (created), and returns the markdown
/// table with the files written.
pub fn error_map_files(dir: &Path, resolution: usize) -> Result<(String, Vec<PathBuf>), AppError> {
    let io = |path: &Path, e: std::io::Error| {
        AppError::input("--map", format!("{}: {e}", path.display()))
    };
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let settings = fin::error_map_settings();
    let (aspects, eccs) = error_map_grid(resolution);
    let fine = fin::compute_error_map(&aspects, &eccs, &settings);
    let svg = fin::error_map_svg(&fine).map_err(|e| AppError::input("--map", e))?;
    let table = fin::compute_error_map(&fin::ERROR_MAP_ASPECTS, &fin::ERROR_MAP_ECC, &settings);
    let md = fin::error_map_markdown(&table);
    let mut files = Vec::new();
    for (name, text) in [
        ("finite-error-map.svg", svg),
        ("finite-error-map.md", md.clone()),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| io(&path, e))?;
        files.push(path);
    }
    Ok((md, files))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid `main.rs` used to build, rebuilt here literally: the same points.
    fn old_grid(n: usize) -> (Vec<f64>, Vec<f64>) {
        let n = n.max(2);
        let aspects: Vec<f64> = (0..=(9 * n / 10))
            .map(|k| 0.1 + k as f64 / n as f64)
            .filter(|&v| v <= 1.0 + 1e-9)
            .collect();
        let eccs: Vec<f64> = (0..=(95 * n / 100)).map(|k| k as f64 / n as f64).collect();
        (aspects, eccs)
    }

    #[test]
    fn the_grid_spans_the_map_in_steps_of_one_over_n() {
        for n in [0, 2, 3, 7, 10, 20, 33, 40, 100, 101] {
            assert_eq!(error_map_grid(n), old_grid(n), "resolution {n}");
        }
        let (a, e) = error_map_grid(10);
        assert_eq!(a.len(), 10);
        assert!((a[9] - 1.0).abs() < 1e-12 && e.len() == 10 && (e[9] - 0.9).abs() < 1e-12);
    }
}
