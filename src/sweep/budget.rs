//! The memory budget: a spec's memory is estimated before anything runs and a spec over
//! the budget is refused, naming the field that drives the estimate (README "Limits").
//! The budget is process-wide; `run --max-memory` raises it.

use std::sync::atomic::{AtomicU64, Ordering};

/// Default memory budget of one command, bytes (2 GiB: a shared 24 GiB machine runs
/// several commands; a service takes specs from anyone).
pub const DEFAULT_MAX_MEMORY_BYTES: u64 = 2 << 30;

/// Measured peak memory per friction-map point (load × speed), bytes: 1.66 GB for
/// 10^6 points (result document, plot points, SVG), BENCHMARKS.md "Limits and memory".
pub const BYTES_PER_MAP_POINT: u64 = 1700;

/// Memory per sampled number kept by a scene run, bytes: an `f64` in its series plus the
/// series' growth slack (result.json is written straight from the series). Measured
/// 13.3: 51 MB more for 150 000 more samples of 26 numbers (paper example and its
/// ideal-joint twin, t_end 0.5 -> 8 s), BENCHMARKS.md "Limits and memory".
pub const BYTES_PER_SAMPLED_NUMBER: u64 = 16;

/// Memory per number of a synthetic variant's signals (series, reduction copies), bytes.
pub const BYTES_PER_SYNTHETIC_NUMBER: u64 = 24;

/// Synthetic variants in flight at once (the simulator's automatic batch size).
pub const SYNTHETIC_IN_FLIGHT: u64 = 64;

static MAX_MEMORY: AtomicU64 = AtomicU64::new(DEFAULT_MAX_MEMORY_BYTES);

/// The memory budget in force, bytes.
pub fn max_memory_bytes() -> u64 {
    MAX_MEMORY.load(Ordering::Relaxed)
}

/// Sets the memory budget for this process, bytes.
pub fn set_max_memory_bytes(bytes: u64) {
    MAX_MEMORY.store(bytes, Ordering::Relaxed);
}

/// Parses a size such as `8G`, `512M`, `64k` or `1000000` (bytes; binary multiples).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let (digits, mult) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => {
            let m: u64 = match c.to_ascii_uppercase() {
                'K' => 1 << 10,
                'M' => 1 << 20,
                'G' => 1 << 30,
                'T' => 1 << 40,
                _ => {
                    return Err(format!(
                        "`{}`: unknown unit (use K, M, G or T)",
                        crate::json::quote(t)
                    ))
                }
            };
            (&t[..i], m)
        }
        _ => (t, 1),
    };
    let n: f64 = digits.parse().map_err(|_| {
        format!(
            "`{}`: expected a size such as 8G or 512M",
            crate::json::quote(t)
        )
    })?;
    let bytes = n * mult as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!(
            "`{}`: must be at least one byte",
            crate::json::quote(t)
        ));
    }
    Ok(bytes as u64)
}

/// A size for messages: `1.5 GiB`, `300 MiB`.
pub fn show_bytes(bytes: f64) -> String {
    const GIB: f64 = (1u64 << 30) as f64;
    const MIB: f64 = (1u64 << 20) as f64;
    if bytes >= GIB {
        format!("{:.1} GiB", bytes / GIB)
    } else {
        format!("{:.0} MiB", (bytes / MIB).ceil())
    }
}

/// `Ok` when `bytes` (an estimate for `what`) fits the budget, else the reason.
pub fn check(what: &str, bytes: f64) -> Result<(), String> {
    let budget = max_memory_bytes();
    if bytes <= budget as f64 {
        Ok(())
    } else {
        Err(format!(
            "{what} needs about {}, over the memory budget of {} (raise it with `run --max-memory`, README \"Limits\")",
            show_bytes(bytes),
            show_bytes(budget as f64)
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("8G"), Ok(8 << 30));
        assert_eq!(parse_size("512m"), Ok(512 << 20));
        assert_eq!(parse_size("1000"), Ok(1000));
        assert_eq!(parse_size("1.5K"), Ok(1536));
        for bad in ["", "x", "8Q", "-1G", "0"] {
            assert!(parse_size(bad).is_err(), "`{bad}` accepted");
        }
        assert!(check("x", 1.0).is_ok());
        let e = check("a map of 1e12 points", 1e15).unwrap_err();
        assert!(e.contains("--max-memory") && e.contains("GiB"), "{e}");
    }
}
