//! Which instruction set the multigrid's lanes chose in this process, and what choosing
//! cost (issue 20, session 41): `cargo run --release --example lanes_choice` (run it a few
//! times: the choice is a measurement).
fn main() {
    let t = std::time::Instant::now();
    let isa = bearing_sweep::bearing::finite::multigrid_lanes();
    println!(
        "lanes {isa:?} (detected widest {:?}), chosen in {:.2} ms",
        bearing_sweep::bearing::LaneIsa::detect(),
        t.elapsed().as_secs_f64() * 1e3
    );
}
