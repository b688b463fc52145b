//! Backend selection: `cpu`, `gpu`, `auto`, and the environment variables that steer
//! the GPU (`WGPU_ADAPTER_NAME`, `BEARING_SWEEP_GPU_PRECISION`); `eval --backend gpu`
//! end to end. One test function, because it changes the process environment.

use bearing_sweep::app::{eval_json, EvalOptions};
use bearing_sweep::backend::{create_backend, BackendError, BackendKind, Precision};
use bearing_sweep::bearing::Accuracy;

fn set(key: &str, value: Option<&str>) {
    match value {
        Some(v) => std::env::set_var(key, v),
        None => std::env::remove_var(key),
    }
}

#[test]
fn backend_kinds_and_environment() {
    let acc = Accuracy::default();
    set("BEARING_SWEEP_GPU_PRECISION", None);

    let (cpu, notice) = create_backend(BackendKind::Cpu, acc).expect("cpu always works");
    assert_eq!(cpu.info().name, "cpu");
    assert!(notice.is_none());

    // An adapter name that matches nothing: `gpu` is a clear error, `auto` the CPU.
    set("WGPU_ADAPTER_NAME", Some("no-such-adapter-xyz"));
    match create_backend(BackendKind::Gpu, acc) {
        Err(BackendError::NoAdapter(msg)) => assert!(
            msg.contains("WGPU_ADAPTER_NAME") || msg.contains("no adapter"),
            "message: {msg}"
        ),
        Err(e) => panic!("expected NoAdapter, got {e}"),
        Ok((b, _)) => panic!("expected an error, got {:?}", b.info()),
    }
    let (auto, notice) = create_backend(BackendKind::Auto, acc).expect("auto never fails");
    assert_eq!(auto.info().name, "cpu");
    let notice = notice.expect("auto falling back says so");
    assert!(
        notice.contains("using the CPU backend") && !notice.contains('\n'),
        "one-line notice: {notice}"
    );
    set("WGPU_ADAPTER_NAME", None);

    // A backend list without Vulkan (the only one this build has) leaves no adapter.
    set("WGPU_BACKEND", Some("metal"));
    assert!(matches!(
        create_backend(BackendKind::Gpu, acc),
        Err(BackendError::NoAdapter(_))
    ));
    set("WGPU_BACKEND", None);

    let gpu = create_backend(BackendKind::Gpu, acc);
    let require = std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1");
    let (gpu, _) = match gpu {
        Ok(g) => g,
        Err(e) if !require => {
            eprintln!("notice: skipping the GPU part: {e}");
            return;
        }
        Err(e) => panic!("BEARING_SWEEP_REQUIRE_GPU=1 but: {e}"),
    };
    let info = gpu.info();
    assert_eq!(info.name, "gpu");
    eprintln!("gpu backend: {} ({:?})", info.device, info.precision);
    // `auto` takes a hardware GPU, never a software rasteriser (lavapipe).
    let software = info.device.contains("Vulkan Cpu");
    let (auto, notice) = create_backend(BackendKind::Auto, acc).expect("auto");
    if software {
        assert_eq!(auto.info().name, "cpu", "auto passes over {}", info.device);
        let notice = notice.expect("auto says why it passed over the adapter");
        assert!(
            notice.contains("software") && !notice.contains('\n'),
            "{notice}"
        );
    } else {
        assert_eq!(
            auto.info().name,
            "gpu",
            "auto takes the GPU when one exists"
        );
    }

    // Choosing the adapter by (part of) its name keeps working, for `gpu` and `auto`.
    let first_word = info
        .device
        .split_whitespace()
        .next()
        .unwrap_or("")
        .to_string();
    set("WGPU_ADAPTER_NAME", Some(&first_word.to_uppercase()));
    let (named, _) = create_backend(BackendKind::Gpu, acc).expect("adapter found by name");
    assert!(named.info().device.starts_with(&first_word));
    let (named_auto, _) = create_backend(BackendKind::Auto, acc).expect("auto");
    assert_eq!(
        named_auto.info().name,
        if software { "cpu" } else { "gpu" },
        "auto takes a named hardware adapter, never a software one ({})",
        info.device
    );
    set("WGPU_ADAPTER_NAME", None);

    // Forcing f32: reported, with a notice that it is looser than 1e-6.
    set("BEARING_SWEEP_GPU_PRECISION", Some("f32"));
    let (g32, notice) = create_backend(BackendKind::Gpu, acc).expect("f32 kernel");
    assert_eq!(g32.info().precision, Precision::F32);
    assert!(notice.is_some_and(|n| n.contains("f32")));
    set("BEARING_SWEEP_GPU_PRECISION", Some("f16"));
    assert!(matches!(
        create_backend(BackendKind::Gpu, acc),
        Err(BackendError::NoAdapter(m)) if m.contains("BEARING_SWEEP_GPU_PRECISION")
    ));
    set("BEARING_SWEEP_GPU_PRECISION", None);

    // `eval --backend gpu` end to end: same statuses and loads as `--backend cpu`.
    let input = r#"{"bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
      "states": [
        {"xi": 1e-4, "yi": 0, "xj": 1e-4, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100},
        {"xi": 1e-4, "yi": 5e-5, "xj": -2e-4, "yj": 1e-4, "vxi": 0.01, "vyi": -0.02, "vxj": 0, "vyj": 0.01, "omega": -300},
        {"xi": 0, "yi": 0, "xj": 0, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 0},
        {"xi": 4e-4, "yi": 0, "xj": 0, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 10}]}"#;
    let run = |backend| {
        eval_json(
            input,
            EvalOptions {
                backend,
                ..EvalOptions::default()
            },
        )
        .expect("eval runs")
        .0
    };
    let (g, c) = (run(BackendKind::Gpu), run(BackendKind::Cpu));
    assert_eq!(g["backend"]["name"], "gpu");
    for k in 0..4 {
        let (gl, cl) = (&g["loads"][k], &c["loads"][k]);
        assert_eq!(gl["status"], cl["status"], "state {k}");
        for f in ["wx", "wy", "mx", "my"] {
            match (gl[f].as_f64(), cl[f].as_f64()) {
                (Some(a), Some(b)) => assert!(
                    (a - b).abs() <= 1e-9 * b.abs().max(1e-12),
                    "state {k} {f}: gpu {a} cpu {b}, tolerance 1e-9 relative"
                ),
                (None, None) => {}
                other => panic!("state {k} {f}: {other:?}"),
            }
        }
    }
}
