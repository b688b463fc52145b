//! `auto` from measurement (`backend::Calibration`): the sweep decision follows the
//! measured figures through the documented model, the measurement of a real GPU backend
//! (lavapipe here; skipped without one unless BEARING_SWEEP_REQUIRE_GPU=1) is usable and
//! cached per device, accuracy and version.

use bearing_sweep::backend::{create_backend, BackendChoice, BackendKind, Calibration};
use bearing_sweep::bearing::Accuracy;

/// Figures of the order measured on an H100 host: CPU kernel 10 µs per state on one
/// thread, GPU round trip 100 µs and 0.03 µs per state.
fn hardware_like() -> Calibration {
    Calibration {
        device: "stand-in".into(),
        accuracy: 1e-6,
        cpu_state_s: 10e-6,
        gpu_call_s: 100e-6,
        gpu_state_s: 0.03e-6,
        gpu_large_states: 1 << 16,
        version: env!("CARGO_PKG_VERSION").into(),
    }
}

#[test]
fn the_sweep_choice_follows_the_measured_figures() {
    let c = hardware_like();
    // Two bearings per variant, 4096 variants per batch, 16 threads: the CPU does 2
    // states per variant-stage at 10 µs over 16 threads; the GPU 2 states at 0.03 µs
    // plus two round trips shared by 4096 variant-stages.
    let (cpu, gpu) = c.sweep_stage_s(2, 4096, 16);
    assert!((cpu - 2.0 * 10e-6 / 16.0).abs() < 1e-15, "{cpu}");
    assert!(
        (gpu - (2.0 * 0.03e-6 + 2.0 / 4096.0 * 100e-6)).abs() < 1e-15,
        "{gpu}"
    );
    let (takes_gpu, reason) = c.sweep_prefers_gpu(2, 4096, 16, 0.5);
    assert!(takes_gpu, "{reason}");
    assert!(reason.starts_with("calibrated: film loads 0.109 µs per variant-stage on the GPU, 1.250 µs on 16 CPU threads ("), "{reason}");
    // A batch of 16 variants pays a round trip per 8 variant-stages: the CPU wins.
    let (takes_gpu, reason) = c.sweep_prefers_gpu(2, 16, 16, 0.5);
    assert!(!takes_gpu, "{reason}");
    // The margin decides near the tie: GPU 0.5 of the CPU is taken at 0.5, not at 0.4.
    let tie = Calibration {
        cpu_state_s: 2.0 * 16.0 * (0.03e-6 + 100e-6 / 4096.0),
        ..c.clone()
    };
    assert!(tie.sweep_prefers_gpu(2, 4096, 16, 0.5 + 1e-9).0);
    assert!(!tie.sweep_prefers_gpu(2, 4096, 16, 0.4).0);
    // The notice line stays one short line: figures without the measurement.
    let line = BackendChoice {
        requested: BackendKind::Auto,
        backend: "gpu".into(),
        reason: c.sweep_prefers_gpu(2, 4096, 16, 0.5).1,
    }
    .line();
    assert!(!line.contains("measured"), "{line}");
    assert!(line.chars().count() <= 140, "{line}");
    // Unusable figures are recognised.
    assert!(c.is_usable());
    assert!(!Calibration {
        gpu_state_s: f64::NAN,
        ..c
    }
    .is_usable());
}

#[test]
fn a_real_gpu_is_measured_once_and_cached_per_device_and_version() {
    let require = std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1");
    let accuracy = Accuracy::new(1e-6).unwrap();
    let mut gpu = match create_backend(BackendKind::Gpu, accuracy) {
        Ok((b, _)) => b,
        Err(e) => {
            assert!(
                !require,
                "BEARING_SWEEP_REQUIRE_GPU=1 but no GPU backend: {e}"
            );
            eprintln!("skipped: no GPU backend ({e})");
            return;
        }
    };
    let dir = std::env::temp_dir().join(format!("bs-calibrate-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let path = dir.join("cal.json");
    let first = Calibration::cached_at(gpu.as_mut(), accuracy, Some(&path), false).unwrap();
    assert!(first.is_usable(), "{first:?}");
    assert_eq!(first.device, gpu.info().device);
    assert_eq!(first.accuracy, 1e-6);
    // Physically plausible: a state costs between 0.1 µs and 1 ms on one CPU thread (11 000
    // counted flops, BENCHMARKS.md "GPU backend"); the large GPU call took longer per call
    // than the small one.
    assert!((1e-7..1e-3).contains(&first.cpu_state_s), "{first:?}");
    assert!(first.gpu_large_states > 64, "{first:?}");
    assert!(path.exists());
    // Read back, not measured again (a new measurement's timings would differ).
    let again = Calibration::cached_at(gpu.as_mut(), accuracy, Some(&path), false).unwrap();
    assert_eq!(again, first);
    // A file from another device (or version) is not used.
    let other = Calibration {
        device: "another device".into(),
        cpu_state_s: 1.0,
        ..first.clone()
    };
    std::fs::write(&path, serde_json::to_string(&other).unwrap()).unwrap();
    let fresh = Calibration::cached_at(gpu.as_mut(), accuracy, Some(&path), false).unwrap();
    assert_eq!(fresh.device, first.device);
    assert!(fresh.cpu_state_s < 1e-3, "{fresh:?}");
    // `refresh` measures anew and replaces the file.
    let refreshed = Calibration::cached_at(gpu.as_mut(), accuracy, Some(&path), true).unwrap();
    assert_ne!(refreshed, fresh);
    let stored: Calibration =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(stored, refreshed);
    let _ = std::fs::remove_dir_all(&dir);
}
