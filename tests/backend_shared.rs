//! One backend shared by several host threads (`backend::Dispatcher`): requests that
//! wait while a dispatch is in flight are merged into one backend call, each requester
//! gets exactly its own states' integrals, a backend failure reaches every requester of
//! the merged call (whose evaluators recompute on the CPU), and a GPU rotor sweep gives
//! the same result on 1 and 3 host threads (skipped without a GPU backend unless
//! BEARING_SWEEP_REQUIRE_GPU=1).

use std::sync::{Arc, Mutex, Weak};
use std::time::{Duration, Instant};

use bearing_sweep::backend::{
    bench_states, create_backend, BackendError, BackendInfo, BackendKind, CpuBackend, Dispatcher,
    FilmBackend, LoadEvaluator, LoadRequest, LoadResult, Precision,
};
use bearing_sweep::bearing::{Accuracy, FilmIntegrals, PackedState, RuleSettings};
use serde_json::json;

mod cli_support;
use cli_support::*;

/// The CPU kernel posing as a GPU; its first call holds until `hold_until` requests are
/// in the dispatcher's queue (so that the others must merge), and it records call sizes.
struct Gate {
    inner: CpuBackend,
    dispatcher: Arc<Mutex<Option<Weak<Dispatcher>>>>,
    hold_until: u64,
    calls: Arc<Mutex<Vec<usize>>>,
    fail: bool,
    /// Panic in the second call (the merged one).
    panic_merged: bool,
}

impl FilmBackend for Gate {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            name: "gpu".into(),
            device: "gate stand-in".into(),
            precision: Precision::F64,
        }
    }
    fn settings(&self) -> RuleSettings {
        self.inner.settings()
    }
    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        let calls = {
            let mut c = self.calls.lock().unwrap();
            c.push(states.len());
            c.len()
        };
        let first = calls == 1;
        assert!(!(self.panic_merged && calls == 2), "the stand-in panics");
        if first {
            let d = self.dispatcher.lock().unwrap().clone();
            let d = d.and_then(|w| w.upgrade()).expect("dispatcher set");
            // Bounded, so that a broken queue fails the test instead of hanging it.
            let start = Instant::now();
            while d.stats().requests < self.hold_until {
                assert!(
                    start.elapsed() < Duration::from_secs(60),
                    "requests never queued: {:?}",
                    d.stats()
                );
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        if self.fail {
            return Err(BackendError::Device("stand-in failure".into()));
        }
        self.inner.integrate(states, out)
    }
}

fn gate(threads: u64, fail: bool) -> (Arc<Dispatcher>, Arc<Mutex<Vec<usize>>>) {
    gate_with(threads, fail, false)
}

fn gate_with(
    threads: u64,
    fail: bool,
    panic_merged: bool,
) -> (Arc<Dispatcher>, Arc<Mutex<Vec<usize>>>) {
    let slot = Arc::new(Mutex::new(None));
    let calls = Arc::new(Mutex::new(Vec::new()));
    let d = Dispatcher::new(Box::new(Gate {
        inner: CpuBackend::new(Accuracy::default(), Some(1)),
        dispatcher: slot.clone(),
        hold_until: threads,
        calls: calls.clone(),
        fail,
        panic_merged,
    }));
    *slot.lock().unwrap() = Some(Arc::downgrade(&d));
    (d, calls)
}

/// `threads` threads each evaluate their share of `requests` once through `d`: the
/// results in request order.
fn evaluate_from_threads(
    d: &Arc<Dispatcher>,
    bearing: &bearing_sweep::bearing::BearingParams,
    requests: &[LoadRequest],
    threads: usize,
) -> (Vec<LoadResult>, Vec<String>) {
    let per = requests.len().div_ceil(threads);
    let mut all = vec![None; requests.len()];
    let mut notices = Vec::new();
    std::thread::scope(|s| {
        let handles: Vec<_> = requests
            .chunks(per)
            .map(|chunk| {
                let handle = d.handle();
                s.spawn(move || {
                    let mut ev = LoadEvaluator::new(handle);
                    let mut out = Vec::new();
                    ev.evaluate(std::slice::from_ref(bearing), chunk, &mut out);
                    (out, ev.take_notices())
                })
            })
            .collect();
        for (k, h) in handles.into_iter().enumerate() {
            let (out, n) = h.join().unwrap();
            for (i, r) in out.into_iter().enumerate() {
                all[k * per + i] = Some(r);
            }
            notices.extend(n);
        }
    });
    (all.into_iter().map(Option::unwrap).collect(), notices)
}

#[test]
fn waiting_requests_merge_into_one_call_and_each_gets_its_own_states() {
    let threads = 4;
    let (bearing, requests) = bench_states(4 * 97, 0.95, 11);
    let (d, calls) = gate(threads as u64, false);
    let (got, notices) = evaluate_from_threads(&d, &bearing, &requests, threads);
    assert!(notices.is_empty(), "{notices:?}");
    // The reference: the same kernel on one thread, all states in one call.
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    let mut want = Vec::new();
    cpu.evaluate(std::slice::from_ref(&bearing), &requests, &mut want);
    assert_eq!(
        got, want,
        "merged results differ from the direct CPU kernel"
    );
    let calls = calls.lock().unwrap().clone();
    let s = d.stats();
    // The first request alone, then the three that queued behind it in one call.
    assert_eq!(calls.len(), 2, "{calls:?}");
    assert_eq!(s.dispatches, 2);
    assert_eq!(s.requests, threads as u64);
    assert_eq!(s.states as usize, calls.iter().sum::<usize>());
    assert_eq!(calls[0] + calls[1], requests.len());
    assert!(
        s.device_busy_s > 0.0 && s.device_busy_s <= s.span_s,
        "{s:?}"
    );
    assert!((0.0..=1.0).contains(&s.device_idle_fraction()));
}

#[test]
fn a_failed_merged_call_reaches_every_requester_and_falls_back_to_the_cpu() {
    let threads = 3;
    let (bearing, requests) = bench_states(3 * 41, 0.9, 5);
    let (d, calls) = gate(threads as u64, true);
    let (got, notices) = evaluate_from_threads(&d, &bearing, &requests, threads);
    assert_eq!(calls.lock().unwrap().len(), 2);
    // Every requester saw the failure and recomputed its own states on the CPU.
    assert_eq!(notices.len(), threads, "{notices:?}");
    assert!(notices.iter().all(|n| n.contains("stand-in failure")));
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    let mut want = Vec::new();
    cpu.evaluate(std::slice::from_ref(&bearing), &requests, &mut want);
    assert_eq!(got, want);
}

/// The paper rotor over 30 clearances x 10 viscosities (300 variants: two GPU sub-batches
/// of 150) for 5 ms on the GPU backend.
fn gpu_spec() -> serde_json::Value {
    json!({
        "kind": "rotor",
        "base": {
            "rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3], "static_unbalance": [0.001, 0.0]},
            "bearings": [
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": 0.2},
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": -0.1}
            ],
            "initial": {"spin": 100.0},
            "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-6, "t_end": 0.005, "sample_interval": 1e-3}
        },
        "axes": [
            {"path": "bearings[*].clearance", "linspace": [1.5e-4, 4e-4, 30]},
            {"path": "bearings[*].viscosity", "linspace": [0.02, 0.08, 10]}
        ],
        "reductions": {"window": {"fraction": 0.5}, "keep": ["orbit"], "points": 20}
    })
}

/// Each variant's steps depend only on its own loads, the kernel computes every state
/// alone, and the GPU sub-batches have a fixed size (so the small-batch CPU routing sees
/// the same calls): 1 and 3 host threads give identical results, and the run section
/// reports the dispatcher's counters.
#[test]
fn gpu_sweep_results_do_not_depend_on_the_number_of_host_threads() {
    let require = std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1");
    if let Err(e) = create_backend(BackendKind::Gpu, Accuracy::default()) {
        assert!(
            !require,
            "BEARING_SWEEP_REQUIRE_GPU=1 but no GPU backend: {e}"
        );
        eprintln!("skipped: no GPU backend ({e})");
        return;
    }
    let dir = scratch("backend-shared", "threads");
    let p = write(&dir, "cv.json", &gpu_spec());
    let mut docs = Vec::new();
    for threads in ["1", "3"] {
        let root = dir.join(format!("t{threads}"));
        let out = bin()
            .args([
                "run",
                p.to_str().unwrap(),
                "--backend",
                "gpu",
                "--out",
                root.to_str().unwrap(),
                "--quiet",
            ])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let d = read(&root.join("cv/result.json"));
        let sim = &d["run"]["simulator"];
        assert_eq!(sim["name"], "gpu");
        assert_eq!(
            sim["variant_threads"],
            json!(threads.parse::<u64>().unwrap())
        );
        let g = &sim["gpu_dispatch"];
        let states = g["states"].as_u64().unwrap();
        assert!(states > 0, "{g}");
        assert!(g["dispatches"].as_u64().unwrap() <= g["requests"].as_u64().unwrap());
        // Two sub-batches of 150 variants (backend's fixed GPU sub-batch size 256).
        assert!(g["requests"].as_u64().unwrap() > 0, "{g}");
        docs.push(deterministic(d));
    }
    assert_eq!(
        serde_json::to_string(&docs[0]).unwrap(),
        serde_json::to_string(&docs[1]).unwrap(),
        "1 and 3 host threads differ on the GPU backend"
    );
}

/// A backend that panics in a merged dispatch does not leave the other requester of that
/// call waiting: it gets an error and recomputes on the CPU; the queue serves later calls.
#[test]
fn a_panicking_backend_releases_the_other_requesters() {
    let threads = 3;
    let (bearing, requests) = bench_states(3 * 29, 0.9, 9);
    let (d, calls) = gate_with(threads as u64, false, true);
    let per = requests.len().div_ceil(threads);
    let outcomes: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = requests
            .chunks(per)
            .map(|chunk| {
                let handle = d.handle();
                let bearing = &bearing;
                s.spawn(move || {
                    let mut ev = LoadEvaluator::new(handle);
                    let mut out = Vec::new();
                    ev.evaluate(std::slice::from_ref(bearing), chunk, &mut out);
                    (out, ev.take_notices())
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join()).collect()
    });
    // The first call alone, the other two merged: that call's leader panicked, the
    // other requester got the error.
    assert_eq!(outcomes.iter().filter(|o| o.is_err()).count(), 1);
    let told: usize = outcomes
        .iter()
        .flatten()
        .map(|(_, n)| n.iter().filter(|n| n.contains("panicked")).count())
        .sum();
    assert_eq!(told, 1);
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    for (k, o) in outcomes.into_iter().enumerate() {
        let Ok((out, _)) = o else { continue };
        let mut want = Vec::new();
        let chunk = &requests[k * per..((k + 1) * per).min(requests.len())];
        cpu.evaluate(std::slice::from_ref(&bearing), chunk, &mut want);
        assert_eq!(out, want);
    }
    // The queue still serves: a later call goes through the (now calm) stand-in.
    let mut ev = LoadEvaluator::new(d.handle());
    let mut out = Vec::new();
    ev.evaluate(std::slice::from_ref(&bearing), &requests[..5], &mut out);
    assert!(out.iter().all(|r| r.is_ok()));
    assert_eq!(calls.lock().unwrap().len(), 3);
}

/// The CPU kernel posing as a GPU with a sibling per extra slot: its first call holds until
/// a second call has run at the same time (on a sibling), so the dispatcher must keep two
/// in flight; every call is counted.
struct Twin {
    inner: CpuBackend,
    active: Arc<std::sync::atomic::AtomicUsize>,
    /// Most calls seen running at once.
    peak: Arc<std::sync::atomic::AtomicUsize>,
    calls: Arc<std::sync::atomic::AtomicUsize>,
    slots: usize,
}

impl FilmBackend for Twin {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            name: "gpu".into(),
            device: "twin stand-in".into(),
            precision: Precision::F64,
        }
    }
    fn settings(&self) -> RuleSettings {
        self.inner.settings()
    }
    fn dispatch_slots(&self) -> usize {
        self.slots
    }
    fn sibling(&self) -> Option<Box<dyn FilmBackend>> {
        Some(Box::new(Twin {
            inner: CpuBackend::new(Accuracy::default(), Some(1)),
            active: self.active.clone(),
            peak: self.peak.clone(),
            calls: self.calls.clone(),
            slots: self.slots,
        }))
    }
    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        use std::sync::atomic::Ordering::SeqCst;
        let first = self.calls.fetch_add(1, SeqCst) == 0;
        let now = self.active.fetch_add(1, SeqCst) + 1;
        self.peak.fetch_max(now, SeqCst);
        if first {
            // Bounded, so that a dispatcher that never overlaps fails instead of hanging.
            let start = Instant::now();
            while self.peak.load(SeqCst) < 2 {
                assert!(
                    start.elapsed() < Duration::from_secs(60),
                    "no second dispatch ran beside the first"
                );
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        let r = self.inner.integrate(states, out);
        self.active.fetch_sub(1, SeqCst);
        r
    }
}

#[test]
fn two_slots_keep_two_dispatches_in_flight_and_each_requester_gets_its_own_states() {
    let threads = 4;
    let (bearing, requests) = bench_states(4 * 53, 0.95, 17);
    let calls = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let d = Dispatcher::new(Box::new(Twin {
        inner: CpuBackend::new(Accuracy::default(), Some(1)),
        active: Arc::new(std::sync::atomic::AtomicUsize::new(0)),
        peak: Arc::new(std::sync::atomic::AtomicUsize::new(0)),
        calls: calls.clone(),
        slots: 2,
    }));
    assert_eq!(d.slots(), 2);
    let (got, notices) = evaluate_from_threads(&d, &bearing, &requests, threads);
    assert!(notices.is_empty(), "{notices:?}");
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    let mut want = Vec::new();
    cpu.evaluate(std::slice::from_ref(&bearing), &requests, &mut want);
    assert_eq!(
        got, want,
        "results through two slots differ from the CPU kernel"
    );
    let s = d.stats();
    assert_eq!(s.slots, 2);
    assert_eq!(s.max_in_flight, 2, "{s:?}");
    assert_eq!(s.requests, threads as u64);
    assert_eq!(
        s.dispatches as usize,
        calls.load(std::sync::atomic::Ordering::SeqCst)
    );
    assert_eq!(s.states as usize, requests.len());
    // Busy is the time with at least one dispatch in flight: never more than the span.
    assert!(
        s.device_busy_s > 0.0 && s.device_busy_s <= s.span_s,
        "{s:?}"
    );
}

/// Slots, waits and merges on the real GPU backend: a sweep with two slots, spinning waits
/// and a merge policy on three threads gives the same result as one slot on one thread at
/// the same lane count (they change which states share a dispatch, never a state's
/// integrals).
#[test]
fn gpu_sweep_results_do_not_depend_on_slots_or_threads() {
    let require = std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1");
    if let Err(e) = create_backend(BackendKind::Gpu, Accuracy::default()) {
        assert!(
            !require,
            "BEARING_SWEEP_REQUIRE_GPU=1 but no GPU backend: {e}"
        );
        eprintln!("skipped: no GPU backend ({e})");
        return;
    }
    let dir = scratch("backend-shared", "slots");
    let p = write(&dir, "cv.json", &gpu_spec());
    let mut docs = Vec::new();
    for (threads, slots) in [("1", "1"), ("3", "2")] {
        let root = dir.join(format!("t{threads}s{slots}"));
        let out = bin()
            .args([
                "run",
                p.to_str().unwrap(),
                "--backend",
                "gpu",
                "--out",
                root.to_str().unwrap(),
                "--quiet",
            ])
            .env("RAYON_NUM_THREADS", threads)
            .env("BEARING_SWEEP_GPU_SLOTS", slots)
            .env("BEARING_SWEEP_GPU_LANES", "8")
            // The second run also spins on its dispatches and lingers for merges.
            .env(
                "BEARING_SWEEP_GPU_WAIT",
                if slots == "2" { "spin" } else { "block" },
            )
            .env(
                "BEARING_SWEEP_GPU_MERGE",
                if slots == "2" { "3:200" } else { "off" },
            )
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let d = read(&root.join("cv/result.json"));
        let g = &d["run"]["simulator"]["gpu_dispatch"];
        assert_eq!(g["slots"], json!(slots.parse::<u64>().unwrap()), "{g}");
        docs.push(deterministic(d));
    }
    assert_eq!(
        serde_json::to_string(&docs[0]).unwrap(),
        serde_json::to_string(&docs[1]).unwrap(),
        "two slots on 3 threads differ from one slot on 1 thread"
    );
}

/// The CPU kernel posing as a GPU with a merge policy: wait up to 0.2 s for 3 requests.
struct Merging(CpuBackend);

impl FilmBackend for Merging {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            name: "gpu".into(),
            device: "merging stand-in".into(),
            precision: Precision::F64,
        }
    }
    fn settings(&self) -> RuleSettings {
        self.0.settings()
    }
    fn merge_policy(&self) -> Option<(usize, Duration)> {
        Some((3, Duration::from_millis(200)))
    }
    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        self.0.integrate(states, out)
    }
}

#[test]
fn a_merge_policy_waits_for_the_active_requesters() {
    // Three threads, two rounds each. In the first round the requesters become active one
    // by one (one may linger in vain for a requester already served: 0.2 s); in the second
    // every thread counts as active, so the first of them waits for the other two and the
    // round is one dispatch. Without the policy an instant backend is free for every
    // request (up to six dispatches).
    let threads = 3;
    let (bearing, requests) = bench_states(3 * 31, 0.95, 41);
    let d = Dispatcher::new(Box::new(Merging(CpuBackend::new(
        Accuracy::default(),
        Some(1),
    ))));
    let mut all = Vec::new();
    for _round in 0..2 {
        let (got, notices) = evaluate_from_threads(&d, &bearing, &requests, threads);
        assert!(notices.is_empty(), "{notices:?}");
        all.push(got);
    }
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    let mut want = Vec::new();
    cpu.evaluate(std::slice::from_ref(&bearing), &requests, &mut want);
    for got in &all {
        assert_eq!(got, &want, "merged results differ from the CPU kernel");
    }
    let s = d.stats();
    assert_eq!(s.requests, 2 * threads as u64);
    assert_eq!(s.states as usize, 2 * requests.len());
    assert!(s.lingered >= 1, "{s:?}");
    // Round 2 is a single dispatch of three requests: at most 3 + 1 dispatches in all.
    assert!(s.dispatches <= 4, "{s:?}");
}
