//! Every WGSL file in `shaders/` parses and validates with naga (the front end wgpu
//! uses), with f64 allowed; the kernel's f32 variant (its precision block swapped by the
//! host) validates too, and without the f64 capability. The shaders' sources are embedded
//! in the test binary (`include_str!`), so that a prebuilt binary runs on a machine
//! without the source tree; where `shaders/` is present, the embedded list must be its
//! `.wgsl` files.

use bearing_sweep::backend::{kernel_source, Precision};
use naga::valid::{Capabilities, ValidationFlags, Validator};

/// Every `.wgsl` file of `shaders/` (name, source), embedded at build time. A shader added
/// to the folder fails `the_embedded_shaders_are_the_folders_files` until it is listed here.
const SHADERS: [(&str, &str); 4] = [
    ("film.wgsl", include_str!("../shaders/film.wgsl")),
    ("finite.wgsl", include_str!("../shaders/finite.wgsl")),
    (
        "finite_jfo.wgsl",
        include_str!("../shaders/finite_jfo.wgsl"),
    ),
    ("finite_mg.wgsl", include_str!("../shaders/finite_mg.wgsl")),
];

fn validate(name: &str, source: &str, caps: Capabilities) {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{name}: WGSL parse error:\n{}", e.emit_to_string(source)));
    Validator::new(ValidationFlags::all(), caps)
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: naga validation error: {e:?}"));
}

#[test]
fn every_shader_file_validates() {
    for (name, source) in SHADERS {
        validate(name, source, Capabilities::FLOAT64);
    }
}

/// Where the source tree is at hand (the build's `shaders/`), its `.wgsl` files are
/// exactly the embedded ones; elsewhere (a prebuilt binary on another machine) there is
/// nothing to compare with, and the embedded sources validated above are the check.
#[test]
fn the_embedded_shaders_are_the_folders_files() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");
    let Ok(entries) = std::fs::read_dir(dir) else {
        eprintln!("{dir} is not here: the embedded shaders alone are checked");
        return;
    };
    let mut on_disk: Vec<String> = entries
        .map(|e| {
            e.expect("readable entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .filter(|n| n.ends_with(".wgsl"))
        .collect();
    on_disk.sort();
    let mut embedded: Vec<&str> = SHADERS.iter().map(|(n, _)| *n).collect();
    embedded.sort();
    assert_eq!(
        on_disk, embedded,
        "the .wgsl files of {dir} (left) against the embedded list SHADERS (right)"
    );
}

#[test]
fn both_kernel_precisions_validate() {
    validate(
        "film.wgsl (f64)",
        &kernel_source(Precision::F64),
        Capabilities::FLOAT64,
    );
    let f32_src = kernel_source(Precision::F32);
    let code_lines_with_f64: Vec<&str> = f32_src
        .lines()
        .filter(|l| !l.trim_start().starts_with("//") && l.contains("f64"))
        .collect();
    assert!(
        code_lines_with_f64.is_empty(),
        "the f32 variant still uses f64: {code_lines_with_f64:?}"
    );
    // The f32 variant must run on adapters without SHADER_F64.
    validate("film.wgsl (f32)", &f32_src, Capabilities::empty());
}

#[test]
fn f64_kernel_needs_the_f64_capability() {
    // Guards the test above: naga does reject f64 without the capability, so the f32
    // variant's acceptance means something.
    let module = naga::front::wgsl::parse_str(&kernel_source(Precision::F64)).expect("parses");
    assert!(
        Validator::new(ValidationFlags::all(), Capabilities::empty())
            .validate(&module)
            .is_err()
    );
}

/// The finite-film kernel (issue 16) validates with f64 and keeps its workgroup memory
/// (field + reduction buffer) within the 16 KiB WebGPU guarantees; its `MAX_NODES` is the
/// host's `FINITE_MAX_NODES`.
#[test]
fn finite_film_kernel_validates_and_fits_workgroup_memory() {
    use bearing_sweep::backend::{FINITE_MAX_NODES, FINITE_WGSL};
    validate("finite.wgsl", FINITE_WGSL, Capabilities::FLOAT64);
    let module = naga::front::wgsl::parse_str(FINITE_WGSL).expect("parses");
    let mut bytes = 0u32;
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).expect("layout");
    for (_, g) in module.global_variables.iter() {
        if g.space == naga::AddressSpace::WorkGroup {
            bytes += layouter[g.ty].size;
        }
    }
    assert!(
        bytes > 0 && bytes <= 16384,
        "finite.wgsl workgroup memory {bytes} B, expected within (0, 16384]"
    );
    let declared = FINITE_WGSL
        .lines()
        .find_map(|l| l.strip_prefix("const MAX_NODES: u32 = "))
        .and_then(|r| r.trim_end_matches("u;").parse::<usize>().ok());
    assert_eq!(declared, Some(FINITE_MAX_NODES), "shader MAX_NODES vs host");
}
