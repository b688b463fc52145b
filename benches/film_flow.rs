//! Cost of the film friction and flow outputs per state (issue 24 item 1): the short
//! film's closed forms against the load rule, and the finite film's post-processing of a
//! converged field against its solve. `cargo bench --bench film_flow`.

use std::time::Instant;

use bearing_sweep::bearing::film_flow::short_film_flow;
use bearing_sweep::bearing::finite::{
    flow_integrals, solution_grid, FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver,
};
use bearing_sweep::bearing::{
    film_loads, pack_state, Accuracy, BearingParams, BearingState, FilmRule,
};

/// Tilted, whirling states of the paper bearing, end eccentricities up to 0.9.
fn states(n: usize) -> Vec<BearingState> {
    let c = BearingParams::paper_table2().clearance;
    (0..n)
        .map(|k| {
            let a = 0.37 * k as f64;
            let (ei, ej) = (
                0.1 + 0.8 * ((k * 7) % 11) as f64 / 10.0,
                0.1 + 0.8 * ((k * 3) % 13) as f64 / 12.0,
            );
            BearingState {
                xi: ei * c * a.cos(),
                yi: ei * c * a.sin(),
                xj: ej * c * (a + 0.3).cos(),
                yj: ej * c * (a + 0.3).sin(),
                vxi: 1e-3 * (a * 1.7).sin(),
                vyi: 1e-3 * (a * 0.9).cos(),
                vxj: -1e-3 * (a * 1.3).sin(),
                vyj: 1e-3 * (a * 2.1).cos(),
                omega: 100.0,
            }
        })
        .collect()
}

fn main() {
    let p = BearingParams::paper_table2();
    let rule = FilmRule::new(Accuracy::default().settings());
    let n = 20_000;
    let st = states(n);
    let t = Instant::now();
    let mut sink = 0.0;
    for s in &st {
        let l = film_loads(&p, s, &rule).unwrap();
        sink += l.wx;
    }
    let loads_us = t.elapsed().as_secs_f64() / n as f64 * 1e6;
    let t = Instant::now();
    for s in &st {
        sink += short_film_flow(&p, s, [1.0, 2.0], [0.1, 0.2]).side_flow_m3_per_s;
    }
    let flow_us = t.elapsed().as_secs_f64() / n as f64 * 1e6;
    println!(
        "short film, {n} tilted whirling states: film_loads (rule + flow) {loads_us:.3} µs/state, \
         of which the film friction and flow closed forms {flow_us:.3} µs ({:.1} %)",
        100.0 * flow_us / loads_us
    );
    let fp = BearingParams {
        model: bearing_sweep::bearing::FilmModel::Finite,
        ..p
    };
    for (name, settings) in [
        ("64x16", FiniteSettings::with_grid(64, 16)),
        ("128x32", FiniteSettings::with_grid(128, 32)),
        ("accuracy 5e-4 (default)", FiniteSettings::default()),
    ] {
        let g = FiniteGrid::from(&settings);
        let m = 16;
        let (mut solve_s, mut post_s) = (0.0, 0.0);
        for s in st.iter().take(m) {
            let packed = pack_state(&fp, s).unwrap();
            let job = FiniteJob::new(&fp, &packed);
            let mut field = Vec::new();
            let t = Instant::now();
            let (_, report) = FiniteSolver::new().solve(&job, &g, &mut field);
            solve_s += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let (nt, nz, th0) = solution_grid(&job, &g, &report);
            let f =
                flow_integrals(&job, &g, nt, nz, th0, s.omega / packed.rate_scale, &field).unwrap();
            post_s += t.elapsed().as_secs_f64();
            sink += f.inlet;
        }
        println!(
            "finite film {name}, {m} states: solve {:.3} ms/state, friction and flow \
             post-processing {:.4} ms/state ({:.2} %)",
            solve_s / m as f64 * 1e3,
            post_s / m as f64 * 1e3,
            100.0 * post_s / solve_s
        );
    }
    std::hint::black_box(sink);
}
