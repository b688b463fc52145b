//! The memory budget: a spec's memory is estimated before anything runs and a spec over
//! the budget is refused, naming the field that drives the estimate (docs/cli.md "Limits").
//! The budget is a value, [`MemoryBudget`], passed in the run options
//! (`sweep::SweepOptions::max_memory`, `app::SceneRunOptions::max_memory`) and the
//! service's config; `run --max-memory` raises it. No process-wide setting.
//!
//! Rotor samples do not grow with `t_end`: each simulation keeps at most
//! [`MemoryBudget::sample_cap`] samples (the budget over the simulations in flight × numbers per
//! sample × [`BYTES_PER_SAMPLED_NUMBER`], a power of two, at least [`MIN_SAMPLE_CAP`]);
//! a full store drops every other sample and doubles its stride (`sample_stride` in the
//! result). More memory means a larger cap and less decimation. Only a spec that cannot
//! fit even at [`MIN_SAMPLE_CAP`] samples per simulation is refused.

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

/// Fewest samples a rotor simulation keeps before decimating, whatever the budget: 4096
/// samples still resolve a whirl window of hundreds of revolutions at a few samples per
/// revolution, and cost 1.7 MB per simulation with two bearings (26 numbers × 16 bytes).
pub const MIN_SAMPLE_CAP: usize = 4096;

/// Memory per number of a synthetic variant's signals (series, reduction copies), bytes.
pub const BYTES_PER_SYNTHETIC_NUMBER: u64 = 24;

/// Synthetic variants in flight at once (the simulator's automatic batch size).
pub const SYNTHETIC_IN_FLIGHT: u64 = 64;

/// A memory budget, bytes: what one command (or one service request's sweep) may use.
/// Default [`DEFAULT_MAX_MEMORY_BYTES`] (2 GiB).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    /// The budget, bytes (at least 1; default 2 GiB).
    pub bytes: u64,
}

impl Default for MemoryBudget {
    fn default() -> Self {
        MemoryBudget {
            bytes: DEFAULT_MAX_MEMORY_BYTES,
        }
    }
}

impl MemoryBudget {
    /// A budget of `bytes`.
    pub fn new(bytes: u64) -> Self {
        MemoryBudget { bytes }
    }

    /// Most samples each of `simulations` rotor simulations in flight at once keeps, with
    /// `numbers_per_sample` numbers per sample: the budget / (simulations × numbers ×
    /// [`BYTES_PER_SAMPLED_NUMBER`]), rounded down to a power of two, at least
    /// [`MIN_SAMPLE_CAP`].
    pub fn sample_cap(self, simulations: usize, numbers_per_sample: usize) -> usize {
        let per_sample = simulations.max(1) as f64
            * numbers_per_sample.max(1) as f64
            * BYTES_PER_SAMPLED_NUMBER as f64;
        // Capped at 2^40 samples so the power of two below fits any usize arithmetic.
        let fit = (self.bytes as f64 / per_sample).clamp(1.0, (1u64 << 40) as f64) as u64;
        let pow2 = 1u64 << (63 - fit.leading_zeros());
        (pow2 as usize).max(MIN_SAMPLE_CAP)
    }

    /// `Ok` when `bytes` (an estimate for `what`) fits the budget, else the reason.
    pub fn check(self, what: &str, bytes: f64) -> Result<(), String> {
        if bytes <= self.bytes as f64 {
            Ok(())
        } else {
            Err(format!(
                "{what} needs about {}, over the memory budget of {} (raise it with `run --max-memory`, docs/cli.md \"Limits\")",
                show_bytes(bytes),
                show_bytes(self.bytes as f64)
            ))
        }
    }
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
        let b = MemoryBudget::default();
        assert!(b.check("x", 1.0).is_ok());
        let e = b.check("a map of 1e12 points", 1e15).unwrap_err();
        assert!(e.contains("--max-memory") && e.contains("GiB"), "{e}");
    }

    #[test]
    fn sample_cap_is_a_power_of_two_from_the_budget() {
        // Default 2 GiB over 1 simulation of 26 numbers x 16 B: 5.16e6 -> 2^22.
        let b = MemoryBudget::default();
        assert_eq!(b.sample_cap(1, 26), 1 << 22);
        // 256 in flight: 20 165 -> 2^14.
        assert_eq!(b.sample_cap(256, 26), 1 << 14);
        // Huge batches stop at the floor.
        assert_eq!(b.sample_cap(1 << 20, 26), MIN_SAMPLE_CAP);
    }
}
