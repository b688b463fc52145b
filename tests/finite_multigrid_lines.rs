//! The multigrid's optional ζ-line smoother (issue 20, session 37; `MgCycle::z_lines`,
//! src/bearing/finite/multigrid.rs `Level::smooth_lines`) solves the same discrete
//! complementarity problem as the point smoother and as projected SOR: on the 12 accuracy
//! states, explicit grids where ζ is the strong direction (B/D = 0.5 at 64 × 16 and
//! 128 × 32, B/D = 0.25 at 128 × 32) and one where it is not (B/D = 1 at 128 × 16, where the
//! lines are not used), both inlets, tolerance 1e-11: the loads agree with the default
//! cycle's and with projected SOR's to 1e-8 relative, with V(2,1) and with V(2,0); a warm
//! start from the solution stays there.

use bearing_sweep::bearing::finite::{
    FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver, Inlet, MgCycle,
};
use bearing_sweep::bearing::{pack_state, BearingParams, FilmModel};

#[path = "support/finite_states.rs"]
mod finite_states;

use finite_states::rel;

#[test]
fn line_smoother_keeps_the_discrete_solution() {
    for (bd, nt, nz) in [
        (0.5, 64, 16),
        (0.5, 128, 32),
        (0.25, 128, 32),
        (1.0, 128, 16),
    ] {
        let base = BearingParams::paper_table2();
        let p = BearingParams {
            model: FilmModel::Finite,
            length: bd * 2.0 * base.radius,
            ..base
        };
        for (label, s) in finite_states::accuracy_states(&p) {
            let packed = pack_state(&p, &s).unwrap();
            let job = FiniteJob::new(&p, &packed);
            for inlet in [Inlet::None, Inlet::MaxFilm] {
                let g = FiniteGrid::from(&FiniteSettings {
                    tolerance: 1e-11,
                    inlet,
                    ..FiniteSettings::with_grid(nt, nz)
                });
                let mut solver = FiniteSolver::new();
                let (a, ra) = solver.solve(&job, &g, &mut Vec::new());
                let (b, rb) = solver.solve_psor(&job, &g, &mut Vec::new());
                assert!(ra.converged && rb.converged, "{label} {nt}x{nz}");
                for (pre, post) in [(2, 1), (2, 0)] {
                    solver.cycle = MgCycle {
                        z_lines: true,
                        pre,
                        post,
                    };
                    let mut field = Vec::new();
                    let (c, rc) = solver.solve(&job, &g, &mut field);
                    assert!(rc.converged, "{label} {nt}x{nz} V({pre},{post}): {rc:?}");
                    let (da, db) = (rel(&c, &a), rel(&c, &b));
                    assert!(
                        da <= 1e-8 && db <= 1e-8,
                        "B/D {bd} {label} {inlet:?} {nt}x{nz} V({pre},{post}) lines: {c:?}, \
                         against the point smoother {da:.2e}, against PSOR {db:.2e} (1e-8)"
                    );
                    // A warm start from the solution stays there.
                    let (w, rw) = solver.solve(&job, &g, &mut field);
                    assert!(
                        rel(&w, &c) <= 1e-9 && rw.sweeps <= 12,
                        "B/D {bd} {label} {nt}x{nz} V({pre},{post}) lines, warm: {rw:?}"
                    );
                    solver.cycle = MgCycle::default();
                }
            }
        }
    }
}
