//! A short measurement of the actual GPU and host, for `auto`: the CPU kernel's cost per
//! state on one thread, and the GPU's round trip and marginal cost per state, on the
//! benchmark states at the run's accuracy. Cached per device, accuracy and program
//! version (docs/cli.md "Backends").

use std::path::PathBuf;
use std::time::Instant;

use super::{bench_states, BackendError, CpuBackend, FilmBackend};
use crate::bearing::{pack_state, Accuracy, PackedState};

/// States in the CPU measurement: enough for ~1-5 ms on one thread (2-10 µs each).
const CPU_STATES: usize = 512;
/// States of the small GPU call whose round trip stands for the latency.
const SMALL_CALL: usize = 64;
/// First size of the large GPU call; doubled until the call takes [`LARGE_CALL_S`].
const LARGE_CALL_START: usize = 4096;
/// Largest size of the large GPU call.
const LARGE_CALL_MAX: usize = 1 << 18;
/// Wall time the large call must reach so that its per-state cost is not latency.
const LARGE_CALL_S: f64 = 0.02;
/// Repetitions of each timing (the median is kept).
const REPS: usize = 5;

/// What the calibration measured.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Calibration {
    /// The GPU's description ([`super::BackendInfo::device`]).
    pub device: String,
    /// Film accuracy measured at (relative).
    pub accuracy: f64,
    /// CPU kernel seconds per state on one thread.
    pub cpu_state_s: f64,
    /// GPU round trip of a [`SMALL_CALL`]-state call (upload, kernel, read-back), s.
    pub gpu_call_s: f64,
    /// GPU marginal seconds per state, from a call large enough to hide the latency.
    pub gpu_state_s: f64,
    /// States in that large call.
    pub gpu_large_states: usize,
    /// The program version that measured.
    pub version: String,
}

/// Median wall seconds of `REPS` runs of `f` (after one warm-up run).
fn median_s(mut f: impl FnMut() -> Result<(), BackendError>) -> Result<f64, BackendError> {
    f()?;
    let mut t = Vec::with_capacity(REPS);
    for _ in 0..REPS {
        let s = Instant::now();
        f()?;
        t.push(s.elapsed().as_secs_f64());
    }
    t.sort_by(f64::total_cmp);
    Ok(t[REPS / 2])
}

/// `n` packed benchmark states (the paper bearing, eccentricity ratios up to 0.95).
fn packed(n: usize) -> Vec<PackedState> {
    let (bearing, requests) = bench_states(n, 0.95, 3);
    requests
        .iter()
        .filter_map(|r| pack_state(&bearing, &r.state).ok())
        .filter(|p| p.rate_scale > 0.0)
        .map(|p| p.state)
        .collect()
}

impl Calibration {
    /// Measures `gpu` and the CPU kernel at `accuracy` (~0.1-0.5 s on hardware).
    pub fn measure(gpu: &mut dyn FilmBackend, accuracy: Accuracy) -> Result<Self, BackendError> {
        let mut out = Vec::new();
        let states = packed(CPU_STATES);
        let mut cpu = CpuBackend::new(accuracy, Some(1));
        let cpu_s = median_s(|| cpu.integrate(&states, &mut out))?;
        let small = packed(SMALL_CALL);
        let gpu_call_s = median_s(|| gpu.integrate(&small, &mut out))?;
        let mut n = LARGE_CALL_START;
        let (large_s, large_n) = loop {
            let big = packed(n);
            let s = median_s(|| gpu.integrate(&big, &mut out))?;
            if s >= LARGE_CALL_S || n >= LARGE_CALL_MAX {
                break (s, big.len());
            }
            n *= 2;
        };
        Ok(Calibration {
            device: gpu.info().device,
            accuracy: accuracy.rtol(),
            cpu_state_s: cpu_s / states.len() as f64,
            gpu_call_s,
            // The large call's cost beyond one round trip, per extra state.
            gpu_state_s: ((large_s - gpu_call_s) / (large_n - small.len()) as f64)
                .max(f64::MIN_POSITIVE),
            gpu_large_states: large_n,
            version: env!("CARGO_PKG_VERSION").to_string(),
        })
    }

    /// The cached calibration of `gpu` at `accuracy` when one exists for this device,
    /// accuracy and version, else a new measurement (saved to the cache; a cache that
    /// cannot be written is skipped). `BEARING_SWEEP_CALIBRATION=refresh` measures anew.
    pub fn cached(gpu: &mut dyn FilmBackend, accuracy: Accuracy) -> Result<Self, BackendError> {
        let path = cache_file(&gpu.info().device, accuracy.rtol());
        let refresh = std::env::var("BEARING_SWEEP_CALIBRATION").is_ok_and(|v| v == "refresh");
        Self::cached_at(gpu, accuracy, path.as_deref(), refresh)
    }

    /// [`Calibration::cached`] with the cache file `path` (`None`: no cache) and whether
    /// to measure anew whatever the file holds.
    pub fn cached_at(
        gpu: &mut dyn FilmBackend,
        accuracy: Accuracy,
        path: Option<&std::path::Path>,
        refresh: bool,
    ) -> Result<Self, BackendError> {
        let device = gpu.info().device;
        if let (Some(p), false) = (path, refresh) {
            if let Some(c) = std::fs::read_to_string(p)
                .ok()
                .and_then(|s| serde_json::from_str::<Calibration>(&s).ok())
                .filter(|c| {
                    c.device == device
                        && c.accuracy == accuracy.rtol()
                        && c.version == env!("CARGO_PKG_VERSION")
                        && c.is_usable()
                })
            {
                return Ok(c);
            }
        }
        let c = Self::measure(gpu, accuracy)?;
        if let Some(p) = path {
            if let Some(dir) = p.parent() {
                let _ = std::fs::create_dir_all(dir);
            }
            if let Ok(s) = serde_json::to_string_pretty(&c) {
                let _ = std::fs::write(p, s);
            }
        }
        Ok(c)
    }

    /// Every figure finite and positive.
    pub fn is_usable(&self) -> bool {
        [self.cpu_state_s, self.gpu_call_s, self.gpu_state_s]
            .iter()
            .all(|x| x.is_finite() && *x > 0.0)
    }

    /// Predicted seconds of `states` film states on the CPU backend over `threads`
    /// threads.
    pub fn cpu_s(&self, states: f64, threads: usize) -> f64 {
        states * self.cpu_state_s / threads.max(1) as f64
    }

    /// Predicted seconds of `states` film states in `calls` GPU calls.
    pub fn gpu_s(&self, states: f64, calls: f64) -> f64 {
        calls * self.gpu_call_s + states * self.gpu_state_s
    }

    /// Film-load seconds per variant-stage of a short-film rotor sweep with `bearings`
    /// bearings per variant and `variants` per lockstep batch: (CPU on `threads`, GPU).
    /// The GPU's sub-batches merge into about two dispatches per stage (one while the
    /// other half of the threads does host work), so each variant-stage carries
    /// `2 / variants` of a round trip. Host work (the integrators) is left out of both:
    /// it runs on all threads either way and overlaps the device on the GPU path.
    pub fn sweep_stage_s(&self, bearings: usize, variants: usize, threads: usize) -> (f64, f64) {
        let b = bearings.max(1) as f64;
        (
            self.cpu_s(b, threads),
            self.gpu_s(b, 2.0 / variants.max(1) as f64),
        )
    }

    /// Whether a short-film rotor sweep (see [`Calibration::sweep_stage_s`]) should run on
    /// the GPU: its predicted film loads per variant-stage at most `margin` of the CPU's.
    /// Returns the answer and the reason (figures, then the measurement in parentheses).
    pub fn sweep_prefers_gpu(
        &self,
        bearings: usize,
        variants: usize,
        threads: usize,
        margin: f64,
    ) -> (bool, String) {
        let (cpu_s, gpu_s) = self.sweep_stage_s(bearings, variants, threads);
        let reason = format!(
            "calibrated: film loads {:.3} µs per variant-stage on the GPU, {:.3} µs on \
             {threads} CPU threads ({}; {bearings} bearings per variant, {variants} variants \
             per batch; the GPU below {margin} of the CPU)",
            1e6 * gpu_s,
            1e6 * cpu_s,
            self.summary()
        );
        (gpu_s <= margin * cpu_s, reason)
    }

    /// The figures in a few words, for a choice's reason.
    pub fn summary(&self) -> String {
        format!(
            "measured: CPU kernel {:.2} µs/state on 1 thread, GPU round trip {:.0} µs + {:.3} µs/state",
            1e6 * self.cpu_state_s,
            1e6 * self.gpu_call_s,
            1e6 * self.gpu_state_s
        )
    }
}

/// Where calibrations are cached: `BEARING_SWEEP_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/bearing-sweep`, else `$HOME/.cache/bearing-sweep`; the file is named
/// after a hash of the device and accuracy. `None` without any of these.
pub fn cache_file(device: &str, accuracy: f64) -> Option<PathBuf> {
    let dir = std::env::var_os("BEARING_SWEEP_CACHE_DIR")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("XDG_CACHE_HOME").map(|d| PathBuf::from(d).join("bearing-sweep"))
        })
        .or_else(|| {
            std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/bearing-sweep"))
        })?;
    // FNV-1a over the key: stable across builds (std's hasher is not).
    let key = format!("{device}|{accuracy:e}");
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in key.bytes() {
        h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
    }
    Some(dir.join(format!("calibration-{h:016x}.json")))
}
