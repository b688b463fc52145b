//! The import graph of `src/` follows ARCHITECTURE.md: every `crate::<room>` reference
//! points to the same room or one below it, so no room imports a room above it and no two
//! rooms import each other. The test reads the source as text (comments and doc links
//! included: a doc link upward is a dependency of the reader too).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The rooms from the bottom up (ARCHITECTURE.md). Rooms on one line share a level: they
/// must not import each other either (checked below as "neither above nor beside").
const LEVELS: &[&[&str]] = &[
    &["numerics", "integrate", "json", "plot", "allocator"],
    &["budget"],
    &["bearing"],
    &["backend"],
    &["rotor"],
    &["stability"],
    &["sweep"],
    &["app"],
    &["service"],
    &["bench"],
    &["cli"],
];

fn level_of(room: &str) -> Option<usize> {
    LEVELS.iter().position(|l| l.contains(&room))
}

/// The room of a source file: its folder under `src/`, or its stem for `src/<room>.rs`.
fn room_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).ok()?;
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    let room = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (room != "lib" && room != "main").then_some(room)
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src/ is readable") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Every `crate::<name>` in `text`, with its line number.
fn crate_refs(text: &str) -> Vec<(usize, String)> {
    let mut refs = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut rest = line;
        while let Some(i) = rest.find("crate::") {
            let before = rest[..i].chars().last();
            rest = &rest[i + "crate::".len()..];
            // `bearing_sweep::crate::` never occurs; skip identifiers ending in `crate`.
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                refs.push((n + 1, name));
            }
        }
    }
    refs
}

#[test]
fn every_room_has_a_level() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut missing: Vec<String> = files
        .iter()
        .filter_map(|f| room_of(&src, f))
        .filter(|r| level_of(r).is_none())
        .collect();
    missing.sort();
    missing.dedup();
    assert!(
        missing.is_empty(),
        "rooms without a level in ARCHITECTURE.md / LEVELS: {missing:?}"
    );
}

#[test]
fn no_room_imports_a_room_above_or_beside_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut violations = Vec::new();
    let mut edges: BTreeMap<(String, String), usize> = BTreeMap::new();
    for file in &files {
        let Some(room) = room_of(&src, file) else {
            continue;
        };
        let Some(level) = level_of(&room) else {
            continue;
        };
        let text = std::fs::read_to_string(file).expect("source file is readable");
        for (line, target) in crate_refs(&text) {
            if target == room {
                continue;
            }
            let Some(target_level) = level_of(&target) else {
                continue; // a macro or item at the crate root, not a room
            };
            *edges.entry((room.clone(), target.clone())).or_default() += 1;
            if target_level >= level {
                violations.push(format!(
                    "{}:{line}: {room} (level {level}) uses crate::{target} (level {target_level})",
                    file.strip_prefix(&src).unwrap_or(file).display()
                ));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "{} upward or sideways imports:\n{}",
        violations.len(),
        violations.join("\n")
    );
    // The same property stated on the graph: no two rooms import each other.
    for (a, b) in edges.keys() {
        assert!(
            !edges.contains_key(&(b.clone(), a.clone())),
            "{a} and {b} import each other"
        );
    }
}

#[test]
fn the_checker_sees_an_upward_import() {
    // The scanner itself: an upward reference in a sample text is found, a room's own
    // and a lower one are allowed, and a longer identifier ending in `crate` is skipped.
    let refs = crate_refs("use crate::sweep::X; // see crate::bearing and my_crate::rotor");
    let names: Vec<&str> = refs.iter().map(|(_, n)| n.as_str()).collect();
    assert_eq!(names, ["sweep", "bearing"]);
    assert!(level_of("sweep") > level_of("rotor"));
    assert!(level_of("numerics") == level_of("plot"));
}

/// Every benchmark lives in the `bench` room (ARCHITECTURE.md "Rules"): no source file
/// elsewhere is a benchmark or load generator by its name.
#[test]
fn benchmarks_live_in_the_bench_room() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let stray: Vec<String> = files
        .iter()
        .filter(|f| room_of(&src, f).is_some_and(|r| r != "bench"))
        .filter(|f| {
            let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or("");
            stem.contains("bench") || stem.contains("loadgen")
        })
        .map(|f| f.strip_prefix(&src).unwrap_or(f).display().to_string())
        .collect();
    assert!(stray.is_empty(), "benchmarks outside src/bench: {stray:?}");
}

/// Public type names defined in one place each: issue 21 found `NewSweep`, `SweepRow`,
/// `Job` and `RunOptions` defined twice (and later `BenchRow`, `Mode` and `Stats`, renamed
/// `LoadsRow`/`BackendRow`, `AxisMode` and `WindowStats`). The one name below is defined
/// twice on purpose: the two `GpuBackend`s are one type with and without the `gpu`
/// feature. A new duplicate fails.
#[test]
fn a_public_type_name_is_defined_once() {
    const KNOWN: &[&str] = &["GpuBackend"];
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut defined: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("source file is readable");
        for line in text.lines() {
            let t = line.trim_start();
            for kw in ["pub struct ", "pub enum ", "pub trait ", "pub type "] {
                if let Some(rest) = t.strip_prefix(kw) {
                    let name: String = rest
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    defined.entry(name).or_default().push(
                        file.strip_prefix(&src)
                            .unwrap_or(file)
                            .display()
                            .to_string(),
                    );
                }
            }
        }
    }
    let twice: Vec<String> = defined
        .iter()
        .filter(|(name, at)| at.len() > 1 && !KNOWN.contains(&name.as_str()))
        .map(|(name, at)| format!("{name}: {at:?}"))
        .collect();
    assert!(
        twice.is_empty(),
        "public names defined twice:\n{}",
        twice.join("\n")
    );
    for name in ["NewSweep", "SweepRow", "Job", "RunOptions"] {
        assert!(
            defined.get(name).is_none_or(|at| at.len() == 1),
            "{name} is defined twice again"
        );
    }
}

/// `main.rs` parses the arguments and calls the library (`cli::run`), nothing else; the
/// `cli` room (argument structs and each command's call) hand-parses no enum either (no
/// match arm on a string literal; `FromStr` impls in the library do that).
#[test]
fn main_parses_arguments_only() {
    /// Lines `main.rs` may have; a ratchet (issue 21: 894 before the `cli` room).
    const MAX_LINES: usize = 15;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let main = root.join("main.rs");
    let mut files = vec![main.clone()];
    rust_files(&root.join("cli"), &mut files);
    for file in &files {
        let text = std::fs::read_to_string(file).expect("source file is readable");
        let arms: Vec<(usize, &str)> = text
            .lines()
            .enumerate()
            .filter(|(_, l)| {
                let t = l.trim_start();
                t.starts_with('"') && t.contains("\" =>")
            })
            .map(|(n, l)| (n + 1, l.trim()))
            .collect();
        assert!(
            arms.is_empty(),
            "string match arms in {}: {arms:?}",
            file.display()
        );
    }
    let text = std::fs::read_to_string(&main).expect("src/main.rs is readable");
    let n = text.lines().count();
    assert!(
        n <= MAX_LINES,
        "main.rs has {n} lines (at most {MAX_LINES})"
    );
    assert!(
        text.contains("cli::run(") && !text.contains("#[derive"),
        "main.rs parses the arguments and calls cli::run; clap structs live in src/cli"
    );
}

/// Issue 21: a sweep's spec is parsed once per sweep on each path through the service,
/// never per call. These are the only calls into the spec parsers in `src/service`
/// (outside its unit tests), each with the reason it runs once: a new call (say, in a
/// route or in `pg::result_document`) fails here and must keep the parsed spec instead.
#[test]
fn the_service_parses_a_spec_once_per_sweep() {
    const ALLOWED: &[(&str, usize, &str)] = &[
        (
            "service/sweeps.rs",
            2,
            "parse_sweep_doc (the service's parser) and check_submission, once per POST",
        ),
        (
            "service/scheduler.rs",
            1,
            "spec_of: parsed once per sweep id, kept bounded",
        ),
        (
            "service/pg/submit.rs",
            1,
            "parse_queued: the library caller parses once",
        ),
        (
            "service/pg/worker.rs",
            1,
            "the compute thread's simulator cache",
        ),
        (
            "service/pg/monitor.rs",
            1,
            "finish: once, when the sweep is done",
        ),
    ];
    const PARSERS: &[&str] = &[
        "parse_spec(",
        "parse_sweep_doc(",
        "parse_sweep_within(",
        "parse_sweep(",
    ];
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src.join("service"), &mut files);
    files.sort();
    let mut found: BTreeMap<String, usize> = BTreeMap::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("source file is readable");
        // Unit tests parse what they like.
        let code = text.split("#[cfg(test)]").next().unwrap_or("");
        let rel = file
            .strip_prefix(&src)
            .unwrap_or(file)
            .display()
            .to_string();
        for line in code.lines() {
            let t = line.trim_start();
            if t.starts_with("//") {
                continue;
            }
            for p in PARSERS {
                let mut rest = t;
                while let Some(i) = rest.find(p) {
                    let before = rest[..i].chars().last();
                    let defines = rest[..i].trim_end().ends_with("fn");
                    rest = &rest[i + p.len()..];
                    if before.is_some_and(|c| c.is_alphanumeric() || c == '_') || defines {
                        continue;
                    }
                    *found.entry(rel.clone()).or_default() += 1;
                }
            }
        }
    }
    let allowed: BTreeMap<String, usize> = ALLOWED
        .iter()
        .map(|(f, n, _)| (f.to_string(), *n))
        .collect();
    assert_eq!(
        found, allowed,
        "spec parser calls in src/service (file: count) differ from the allowed ones"
    );
}
