//! Finishing a sweep, whoever runs it: one batch of variants turned into their stream
//! lines, the result document, and the figures drawn from the light part of the
//! variants (their lines without the series). `run`, `merge`, the service's scheduler,
//! the PostgreSQL workers and monitor and the result route all go through here, so a
//! sweep's lines, result and figures are the same bytes whichever path made them.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use serde_json::{json, Value};

use super::expand::{Expansion, Variant};
use super::friction_map::FrictionMapSpec;
use super::reduce::units;
use super::runner::{spec_hash, variant_line, BatchSimulator, Outcome, Shard, VariantJob};
use super::spec::{parse_spec, SweepKind, SweepSpec};
use super::SweepError;

/// Format tag of a result file.
pub const RESULT_FORMAT: &str = "bearing-sweep/sweep-result/1";

/// A parsed sweep document, of any kind.
pub enum ParsedSweep {
    /// A rotor, synthetic or stability sweep (runs through the runner).
    Runner(Box<SweepSpec>),
    /// A friction map (no dynamics; one document).
    FrictionMap(Box<FrictionMapSpec>),
}

impl ParsedSweep {
    /// Its kind.
    pub fn kind(&self) -> SweepKind {
        match self {
            ParsedSweep::Runner(s) => s.kind,
            ParsedSweep::FrictionMap(_) => SweepKind::FrictionMap,
        }
    }

    /// Variants (friction-map points) in it.
    pub fn count(&self) -> u64 {
        match self {
            ParsedSweep::Runner(s) => Expansion::new(s).count(),
            ParsedSweep::FrictionMap(f) => (f.load.len() * f.speed.len()) as u64,
        }
    }

    /// The spec's name (empty when it has none).
    pub fn name(&self) -> String {
        match self {
            ParsedSweep::Runner(s) => s.name.clone().unwrap_or_default(),
            ParsedSweep::FrictionMap(f) => f.name.clone().unwrap_or_default(),
        }
    }
}

/// Parses a sweep document of any kind (dispatching on [`SweepKind::of`]); `spec_dir`
/// resolves a `base` given as a file name.
pub fn parse_sweep(doc: &Value, spec_dir: Option<&Path>) -> Result<ParsedSweep, SweepError> {
    parse_sweep_within(doc, spec_dir, crate::budget::MemoryBudget::default())
}

/// [`parse_sweep`] within the memory budget `budget` (a friction map's size is checked
/// against it as it is parsed).
pub fn parse_sweep_within(
    doc: &Value,
    spec_dir: Option<&Path>,
    budget: crate::budget::MemoryBudget,
) -> Result<ParsedSweep, SweepError> {
    match SweepKind::of(doc) {
        Some(SweepKind::FrictionMap) => Ok(ParsedSweep::FrictionMap(Box::new(
            FrictionMapSpec::parse_within(doc, budget)?,
        ))),
        _ => Ok(ParsedSweep::Runner(Box::new(parse_spec(doc, spec_dir)?))),
    }
}

/// Runs the variants `ids` of `spec` as one batch on `sim` and calls
/// `done(variant, outcome)` once per variant, as each finishes. A variant the simulator
/// reports twice is taken once; one it does not report becomes `internal_error` after the
/// batch. Once `cancel` is set the simulator stops early (every variant is still
/// reported: the caller decides what a cancelled outcome is worth).
pub fn run_batch(
    spec: &SweepSpec,
    exp: &Expansion,
    sim: &mut dyn BatchSimulator,
    ids: &[u64],
    cancel: &AtomicBool,
    done: &mut dyn FnMut(&Variant, Outcome),
) {
    let variants: Vec<Variant> = ids.iter().map(|&id| exp.variant(spec, id)).collect();
    let jobs: Vec<VariantJob> = variants
        .iter()
        .map(|v| VariantJob {
            id: v.id,
            scene: v.scene.clone(),
        })
        .collect();
    let mut reported = vec![false; jobs.len()];
    let mut on_done = |k: usize, outcome: Outcome| {
        if k >= reported.len() || reported[k] {
            return;
        }
        reported[k] = true;
        done(&variants[k], outcome);
    };
    sim.run_batch_cancellable(&jobs, cancel, &mut on_done);
    for k in 0..jobs.len() {
        on_done(
            k,
            Outcome::failed(
                "internal_error",
                "the simulator did not report this variant".into(),
            ),
        );
    }
}

/// A finished variant's stream line (compact JSON) and whether its status is `ok`.
pub fn finished_line(spec: &SweepSpec, v: &Variant, outcome: Outcome) -> (bool, String) {
    let ok = outcome.status == "ok";
    (ok, variant_line(spec, v, outcome).to_string())
}

/// The result document of a sweep (or of one shard of it) without its variants
/// (`variants: []`): `run` writes it with the variant lines in id order
/// ([`super::runner::write_result_doc`]), the service serves it the same way.
pub fn result_document(
    spec: &SweepSpec,
    settings: &Value,
    shard: Option<Shard>,
    total: u64,
    run: Value,
) -> Value {
    json!({
        "format": RESULT_FORMAT,
        "name": spec.name,
        "kind": spec.kind.name(),
        "spec_hash": spec_hash(spec),
        "spec": spec.canonical,
        "settings": settings,
        "count": total,
        "shard": shard.map(Shard::to_json),
        "units": units(),
        "variants": [],
        "run": run,
    })
}

/// A variant line without its series (what the figures and the CSV read); `None` for a
/// line that is not JSON.
pub fn light_variant(line: &str) -> Option<Value> {
    serde_json::from_str::<Value>(line).ok().map(without_series)
}

/// A variant line without its series, as text: the line itself when it has none or is
/// not JSON (the CSV export reads these; parsing only the lines that carry a series).
pub fn light_line(line: &str) -> String {
    if !line.contains("\"series\"") {
        return line.to_string();
    }
    light_variant(line).map_or_else(|| line.to_string(), |v| v.to_string())
}

/// A page of variant lines as the JSON object `{"offset", "total", "variants": [...]}`
/// (compact), the lines as stored: their numbers are not re-encoded.
pub fn variant_page(offset: u64, total: u64, lines: &[(u64, String)]) -> String {
    let mut body = format!("{{\"offset\":{offset},\"total\":{total},\"variants\":[");
    for (k, (_, line)) in lines.iter().enumerate() {
        if k > 0 {
            body.push(',');
        }
        body.push_str(line);
    }
    body.push_str("]}");
    body
}

/// `v` without its `series`.
pub fn without_series(mut v: Value) -> Value {
    if let Some(o) = v.as_object_mut() {
        o.remove("series");
    }
    v
}

/// The spec's figures of a complete sweep, collected from its variants (light part only,
/// so memory does not grow with the kept series) and drawn at the end.
pub struct Figures<'a> {
    spec: &'a SweepSpec,
    light: Vec<Value>,
}

/// One drawn figure: its name and its SVG text, or why it could not be drawn.
pub type DrawnFigure = (String, Result<String, String>);

impl<'a> Figures<'a> {
    /// Figures of `spec` (none collected yet).
    pub fn new(spec: &'a SweepSpec) -> Self {
        Figures {
            spec,
            light: Vec::new(),
        }
    }

    /// Whether the spec asks for any figure (otherwise nothing needs collecting).
    pub fn wanted(&self) -> bool {
        !self.spec.plots.is_empty()
    }

    /// Adds the variant of a stream line (lines that are not JSON are skipped).
    pub fn add_line(&mut self, line: &str) {
        if self.wanted() {
            if let Some(v) = light_variant(line) {
                self.light.push(v);
            }
        }
    }

    /// Adds a variant already parsed (its series is dropped).
    pub fn add_value(&mut self, v: Value) {
        if self.wanted() {
            self.light.push(without_series(v));
        }
    }

    /// Draws every figure of the spec, in spec order.
    pub fn draw(&self) -> Vec<DrawnFigure> {
        draw_figures(self.spec, &self.light)
    }
}

/// Draws every figure of `spec` from the light variants `light`, in spec order.
pub fn draw_figures(spec: &SweepSpec, light: &[Value]) -> Vec<DrawnFigure> {
    spec.plots
        .iter()
        .map(|p| (p.name.clone(), super::plots::render(light, p)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::parse_spec;
    use crate::sweep::runner::VariantJob;

    fn spec() -> SweepSpec {
        parse_spec(
            &json!({"kind": "synthetic", "base": {"spin": 100.0},
                    "axes": [{"path": "spin", "values": [50.0, 60.0, 70.0]}]}),
            None,
        )
        .unwrap()
    }

    /// Reports the first job twice (a different status the second time), skips the
    /// second, and reports the rest once.
    struct Sloppy;

    impl BatchSimulator for Sloppy {
        fn auto_batch_size(&self) -> usize {
            3
        }
        fn info(&self) -> Value {
            Value::Null
        }
        fn run_batch(&mut self, jobs: &[VariantJob], done: &mut dyn FnMut(usize, Outcome)) {
            done(0, Outcome::failed("first", "first report".into()));
            done(0, Outcome::failed("second", "second report".into()));
            for k in 2..jobs.len() {
                done(k, Outcome::failed("third", String::new()));
            }
            // An index out of range is ignored.
            done(jobs.len(), Outcome::failed("bogus", String::new()));
        }
    }

    #[test]
    fn a_batch_reports_each_variant_once_and_the_missing_as_internal_errors() {
        let spec = spec();
        let exp = Expansion::new(&spec);
        let mut seen = Vec::new();
        run_batch(
            &spec,
            &exp,
            &mut Sloppy,
            &[0, 1, 2],
            &AtomicBool::new(false),
            &mut |v, o| seen.push((v.id, o.status)),
        );
        assert_eq!(
            seen,
            vec![
                (0, "first".to_string()),
                (2, "third".to_string()),
                (1, "internal_error".to_string())
            ]
        );
    }

    #[test]
    fn a_page_keeps_the_stored_lines_verbatim() {
        let lines = vec![
            (3, r#"{"id":3,"x":1.0}"#.to_string()),
            (4, r#"{"id":4,"x":2.50}"#.to_string()),
        ];
        let page = variant_page(3, 9, &lines);
        assert_eq!(
            page,
            r#"{"offset":3,"total":9,"variants":[{"id":3,"x":1.0},{"id":4,"x":2.50}]}"#
        );
        let v: Value = serde_json::from_str(&page).unwrap();
        assert_eq!(v["variants"].as_array().unwrap().len(), 2);
        assert_eq!(
            variant_page(0, 0, &[]),
            r#"{"offset":0,"total":0,"variants":[]}"#
        );
    }

    #[test]
    fn figures_read_the_light_part_only() {
        let spec = spec();
        assert!(!Figures::new(&spec).wanted(), "the spec asks for no plot");
        let v = light_variant(r#"{"id":1,"series":{"t":[0,1]},"reductions":null}"#).unwrap();
        assert_eq!(v, json!({"id": 1, "reductions": null}));
        assert!(light_variant("not json").is_none());
    }
}
