//! The rotor samples' store alone (issue 28, sixteenth pass): `V` variants' decimating
//! stores ([`SeriesStore::for_run`]) take one sample each in turn, as a lockstep batch
//! records them, until 256 x 1 001 samples are stored (two bearings a sample, 26 numbers);
//! prints the time per sample, best of three rounds.
//!
//! Run (harness-less): `cargo bench --bench sample_store -- [V]` (default 256). With the
//! samples pushed straight into their columns, the time per sample grew with `V` (each
//! sample touched ~26 pages last touched a round of variants earlier); staged in rows it
//! stays nearly flat.

use std::time::Instant;

use bearing_sweep::rotor::{BearingSample, Sample, SampleObserver, SeriesStore};

fn main() {
    let variants: usize = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with("--"))
        .and_then(|a| a.parse().ok())
        .unwrap_or(256)
        .max(1);
    let samples = 256 * 1001 / variants;
    // The default budget's cap at 256 variants is far above the 1 001 samples of a run.
    let cap = 1 << 16;
    let b = [BearingSample {
        xi: 1e-5,
        yi: 2e-5,
        xj: 3e-5,
        yj: 4e-5,
        h_min: 1e-4,
        eccentricity_max: 0.5,
        wx: 1.0,
        wy: 2.0,
        mz: 0.1,
        friction_coefficient: Some(0.01),
        thermal: None,
        film: None,
    }; 2];
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let mut stores: Vec<SeriesStore> = (0..variants)
            .map(|_| SeriesStore::for_run(cap, samples))
            .collect();
        let t0 = Instant::now();
        for k in 0..samples {
            for (i, s) in stores.iter_mut().enumerate() {
                let x = Sample {
                    t: k as f64 * 5e-4,
                    x_g: i as f64,
                    y_g: 1.0,
                    spin: 100.0,
                    kinetic_energy: 1.0,
                    work: 0.0,
                    bearings: &b,
                };
                s.observe(std::hint::black_box(&x));
            }
        }
        let series: Vec<_> = stores.iter_mut().map(|s| s.take_series()).collect();
        best = best.min(t0.elapsed().as_secs_f64());
        assert!(series.iter().all(|s| s.len() == samples));
    }
    println!(
        "sample store: {variants} variants x {samples} samples, {:.1} ns a sample (best of 3)",
        best * 1e9 / (variants * samples) as f64
    );
}
