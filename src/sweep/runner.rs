//! The sweep runner: expands the variants, keeps this shard's, skips those already in the
//! output stream (resume), runs the rest in batches on a [`BatchSimulator`], streams each
//! finished variant as one JSON line (written and flushed at once, so an interrupted run
//! loses nothing finished), then writes the final JSON with the variants sorted by id.
//! Merging shard outputs is in `super::merge`.
//!
//! Files, for `--out R.json`: the stream `R.jsonl` (first line a header naming the spec
//! hash, the settings and the shard; then one variant per line) and the result `R.json`,
//! written to a temporary file and renamed. Everything in the result except its `run`
//! section (timings, machine, resumes) is deterministic: the same spec and settings give
//! the same bytes however the run was sharded, batched or interrupted.

use std::cell::Cell;
use std::collections::{BTreeMap, BTreeSet};
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::{json, Map, Value};

use super::expand::Expansion;
use super::progress::Progress;
use super::reduce::{kept_series, reduce, units, Signals};
use super::spec::SweepSpec;
use super::SweepError;

/// Format tag of a result file.
pub const RESULT_FORMAT: &str = "bearing-sweep/sweep-result/1";
/// Format tag of a stream header.
pub const STREAM_FORMAT: &str = "bearing-sweep/sweep-stream/1";

/// One variant handed to the simulator.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// Variant id.
    pub id: u64,
    /// Its scene (validated).
    pub scene: Value,
}

/// What the simulator reports for one variant.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// `"ok"` or a failure status (e.g. `"film_breakdown"`).
    pub status: String,
    /// Details for a non-ok status.
    pub message: Option<String>,
    /// The time series (up to the failure, if any).
    pub signals: Option<Signals>,
    /// Simulator-specific deterministic extras (e.g. step counts), stored as `"sim"`.
    pub extra: Option<Value>,
}

impl Outcome {
    /// A finished variant.
    pub fn ok(signals: Signals) -> Self {
        Outcome {
            status: "ok".into(),
            message: None,
            signals: Some(signals),
            extra: None,
        }
    }

    /// A variant that produced no signals.
    pub fn failed(status: &str, message: String) -> Self {
        Outcome {
            status: status.into(),
            message: Some(message),
            signals: None,
            extra: None,
        }
    }
}

/// Runs batches of variants: the rotor integrator in lockstep, or a stand-in.
pub trait BatchSimulator {
    /// Batch size for `--batch-size auto`.
    fn auto_batch_size(&self) -> usize;
    /// Description for the result's `run` section (backend, device).
    fn info(&self) -> Value;
    /// Simulates `jobs`, calling `done(index in jobs, outcome)` once per job as it
    /// finishes, in any order. A failing variant reports a status; it never stops the batch.
    fn run_batch(&mut self, jobs: &[Job], done: &mut dyn FnMut(usize, Outcome));
    /// Notices for the user (e.g. a GPU fallback), drained.
    fn take_notices(&mut self) -> Vec<String> {
        Vec::new()
    }
}

/// A deterministic slice of the variants: variant `id` belongs to shard `id mod count`
/// (round-robin, so every shard gets a similar mix of cheap and costly variants).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: u64,
    /// Number of shards.
    pub count: u64,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}`: expected K/N, e.g. 3/16"))?;
        let index: u64 = k
            .trim()
            .parse()
            .map_err(|_| format!("`{s}`: K is not an integer"))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| format!("`{s}`: N is not an integer"))?;
        if count == 0 || index >= count {
            return Err(format!("`{s}`: needs 0 <= K < N"));
        }
        Ok(Shard { index, count })
    }
}

impl Shard {
    /// Whether variant `id` is in this shard.
    pub fn owns(&self, id: u64) -> bool {
        id % self.count == self.index
    }

    fn to_json(self) -> Value {
        json!({"index": self.index, "count": self.count})
    }
}

/// Batch size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BatchSize {
    /// The simulator's choice.
    Auto,
    /// This many variants per batch.
    Fixed(usize),
}

impl std::str::FromStr for BatchSize {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(BatchSize::Auto);
        }
        match s.parse::<usize>() {
            Ok(n) if n > 0 => Ok(BatchSize::Fixed(n)),
            _ => Err(format!("`{s}`: expected `auto` or a positive integer")),
        }
    }
}

/// How to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Result file; the stream is the same path with extension `jsonl`.
    pub out: PathBuf,
    /// Only this shard.
    pub shard: Option<Shard>,
    /// Variants per batch.
    pub batch: BatchSize,
    /// Draw a progress bar (only on a terminal).
    pub progress: bool,
    /// Settings that change results (backend kind, accuracy, ...): recorded in the result
    /// and checked on resume and merge.
    pub settings: Value,
}

/// What a run did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    /// Variants in the whole expansion.
    pub total: u64,
    /// Variants in this shard.
    pub in_shard: u64,
    /// Already in the stream (resumed).
    pub skipped: u64,
    /// Run now.
    pub ran: u64,
    /// Variants whose status is not `ok`, in the result.
    pub not_ok: u64,
    /// The result file.
    pub result: PathBuf,
    /// The stream file.
    pub stream: PathBuf,
    /// Plots written (complete results only), or why one was not.
    pub plots: Vec<Result<PathBuf, String>>,
}

/// The stream path for result path `out`: extension replaced by `jsonl`.
pub fn stream_path(out: &Path) -> PathBuf {
    out.with_extension("jsonl")
}

/// FNV-1a 64 of `bytes` (stable across platforms and releases, unlike `DefaultHasher`).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Hash of the canonical spec (keys sorted), as 16 hex digits.
pub fn spec_hash(spec: &SweepSpec) -> String {
    let text = serde_json::to_string(&spec.canonical).unwrap_or_default();
    format!("{:016x}", fnv1a64(text.as_bytes()))
}

fn header(spec: &SweepSpec, opts: &RunOptions, total: u64) -> Value {
    json!({"format": STREAM_FORMAT, "spec_hash": spec_hash(spec), "settings": opts.settings,
           "shard": opts.shard.map(Shard::to_json), "count": total})
}

/// Where one finished variant's line sits in the stream.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LineRef {
    /// Byte offset of the line.
    offset: u64,
    /// Length without the newline.
    len: usize,
    /// Its status is `ok`.
    ok: bool,
}

/// Reads an existing stream: checks its header against `expected`, returns where each
/// finished variant's line is (first occurrence per id), and the byte length of its
/// intact prefix (a torn last line, left by a kill in mid-write, is excluded and gets
/// truncated). Memory: a few words per variant, whatever the lines hold.
fn read_stream(path: &Path, expected: &Value) -> Result<(BTreeMap<u64, LineRef>, u64), SweepError> {
    let file = File::open(path).map_err(|e| SweepError::io(path, e))?;
    let mut reader = BufReader::new(file);
    let mut line = Vec::new();
    let mut good_len = 0u64;
    let mut lines = BTreeMap::new();
    let mut first = true;
    let mut line_no = 0;
    loop {
        line.clear();
        let n = reader
            .read_until(b'\n', &mut line)
            .map_err(|e| SweepError::io(path, e))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let complete = line.last() == Some(&b'\n');
        let parsed: Option<Value> = serde_json::from_slice(&line).ok();
        let Some(v) = parsed.filter(|_| complete) else {
            // Torn: only acceptable as the last line.
            let mut rest = Vec::new();
            let _ = std::io::Read::read_to_end(&mut reader, &mut rest);
            if rest.iter().all(|b| b.is_ascii_whitespace()) {
                break;
            }
            return Err(SweepError::Output(format!(
                "{}: line {line_no} is not valid JSON and is not the last line; the stream is damaged (move it away to start over)",
                path.display()
            )));
        };
        if first {
            first = false;
            if v.get("format").and_then(Value::as_str) != Some(STREAM_FORMAT) {
                return Err(SweepError::Output(format!(
                    "{}: not a bearing-sweep stream (first line has no format `{STREAM_FORMAT}`)",
                    path.display()
                )));
            }
            if &v != expected {
                return Err(SweepError::Output(format!(
                    "{}: written by a different spec, settings or shard (its header {v}, this run {expected}); use another --out or delete it",
                    path.display()
                )));
            }
        } else {
            let id = v.get("id").and_then(Value::as_u64).ok_or_else(|| {
                SweepError::Output(format!(
                    "{}: line {line_no} has no variant id",
                    path.display()
                ))
            })?;
            let ok = v.get("status").and_then(Value::as_str) == Some("ok");
            lines.entry(id).or_insert(LineRef {
                offset: good_len,
                len: n - 1,
                ok,
            });
        }
        good_len += n as u64;
    }
    if first {
        // Empty file (killed before the header was written).
        good_len = 0;
    }
    Ok((lines, good_len))
}

/// Runs the sweep (this shard of it), resuming from an existing stream.
pub fn run_sweep(
    spec: &SweepSpec,
    validator: &super::expand::SceneValidator,
    sim: &mut dyn BatchSimulator,
    opts: &RunOptions,
    notice: &mut dyn FnMut(String),
) -> Result<RunSummary, SweepError> {
    let started = Instant::now();
    let exp = Expansion::new(spec);
    let total = exp.count();
    exp.validate_all(spec, validator)?;
    let owns = |id: u64| opts.shard.is_none_or(|s| s.owns(id));
    let mine: Vec<u64> = (0..total).filter(|&id| owns(id)).collect();
    let stream = stream_path(&opts.out);
    if let Some(dir) = stream.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| SweepError::io(dir, e))?;
    }
    let head = header(spec, opts, total);
    let mut done: BTreeSet<u64> = BTreeSet::new();
    let mut file = if stream.exists() {
        let (lines, good_len) = read_stream(&stream, &head)?;
        for id in lines.keys() {
            if !owns(*id) || *id >= total {
                return Err(SweepError::Output(format!(
                    "{}: holds variant {id}, which is not in this run",
                    stream.display()
                )));
            }
        }
        done.extend(lines.keys());
        let mut f = OpenOptions::new()
            .read(true)
            .write(true)
            .open(&stream)
            .map_err(|e| SweepError::io(&stream, e))?;
        f.set_len(good_len)
            .map_err(|e| SweepError::io(&stream, e))?;
        f.seek(SeekFrom::End(0))
            .map_err(|e| SweepError::io(&stream, e))?;
        if good_len == 0 {
            writeln!(f, "{head}").map_err(|e| SweepError::io(&stream, e))?;
        }
        if !done.is_empty() {
            notice(format!(
                "resuming: {} of {} variants already in {}",
                done.len(),
                mine.len(),
                stream.display()
            ));
        }
        f
    } else {
        let mut f = File::create(&stream).map_err(|e| SweepError::io(&stream, e))?;
        writeln!(f, "{head}").map_err(|e| SweepError::io(&stream, e))?;
        f
    };
    file.flush().map_err(|e| SweepError::io(&stream, e))?;
    let todo: Vec<u64> = mine
        .iter()
        .copied()
        .filter(|id| !done.contains(id))
        .collect();
    let skipped = (mine.len() - todo.len()) as u64;
    let batch = match opts.batch {
        BatchSize::Auto => sim.auto_batch_size().max(1),
        BatchSize::Fixed(n) => n,
    };
    let mut progress = Progress::new(opts.progress, mine.len() as u64, skipped);
    let mut write_error: Option<SweepError> = None;
    let sim_started = Instant::now();
    for chunk in todo.chunks(batch) {
        let variants: Vec<_> = chunk.iter().map(|&id| exp.variant(spec, id)).collect();
        let jobs: Vec<Job> = variants
            .iter()
            .map(|v| Job {
                id: v.id,
                scene: v.scene.clone(),
            })
            .collect();
        let reported: Vec<Cell<bool>> = vec![Cell::new(false); jobs.len()];
        {
            let mut on_done = |k: usize, outcome: Outcome| {
                if k >= reported.len() || reported[k].get() || write_error.is_some() {
                    return;
                }
                reported[k].set(true);
                // One write call per line: a kill leaves at most one torn last line.
                let mut line = variant_line(spec, &variants[k], outcome).to_string();
                line.push('\n');
                let result = file.write_all(line.as_bytes()).and_then(|_| file.flush());
                if let Err(e) = result {
                    write_error = Some(SweepError::io(&stream, e));
                }
                progress.inc();
            };
            sim.run_batch(&jobs, &mut on_done);
            let missing: Vec<usize> = (0..jobs.len()).filter(|&k| !reported[k].get()).collect();
            for k in missing {
                {
                    on_done(
                        k,
                        Outcome::failed(
                            "internal_error",
                            "the simulator did not report this variant".into(),
                        ),
                    );
                }
            }
        }
        if let Some(e) = write_error.take() {
            return Err(e);
        }
        // Durable at batch ends (each line is already in the OS after its flush).
        let _ = file.sync_data();
        for n in sim.take_notices() {
            notice(n);
        }
    }
    progress.finish();
    drop(file);
    let sim_s = sim_started.elapsed().as_secs_f64();
    let (lines, _) = read_stream(&stream, &head)?;
    let missing: Vec<u64> = mine
        .iter()
        .copied()
        .filter(|id| !lines.contains_key(id))
        .take(5)
        .collect();
    if !missing.is_empty() {
        return Err(SweepError::Output(format!(
            "{}: variants {missing:?} missing after the run",
            stream.display()
        )));
    }
    let not_ok = lines.values().filter(|l| !l.ok).count() as u64;
    let ran = todo.len() as u64;
    let run = json!({
        "simulator": sim.info(),
        "variants_run": ran,
        "variants_resumed": skipped,
        "simulation_wall_s": sim_s,
        "variants_per_s": if sim_s > 0.0 { ran as f64 / sim_s } else { 0.0 },
        "wall_s": started.elapsed().as_secs_f64(),
        "peak_rss_bytes": peak_rss_bytes(),
    });
    let doc = result_doc(spec, &opts.settings, opts.shard, total, run);
    // Stream the variants from the stream file into the result in id order, keeping the
    // light part (params, reductions) only when plots need it.
    let mut reader = File::open(&stream).map_err(|e| SweepError::io(&stream, e))?;
    let want_plots = opts.shard.is_none() && !spec.plots.is_empty();
    let mut light = Vec::new();
    let mut buf = Vec::new();
    let mut next = |r: &LineRef| -> Result<String, SweepError> {
        buf.resize(r.len, 0);
        reader
            .seek(SeekFrom::Start(r.offset))
            .and_then(|_| std::io::Read::read_exact(&mut reader, &mut buf))
            .map_err(|e| SweepError::io(&stream, e))?;
        let text = String::from_utf8_lossy(&buf).into_owned();
        if want_plots {
            if let Ok(mut v) = serde_json::from_str::<Value>(&text) {
                if let Some(o) = v.as_object_mut() {
                    o.remove("series");
                }
                light.push(v);
            }
        }
        Ok(text)
    };
    let mut iter = lines.values().map(&mut next);
    write_result_streamed(&opts.out, &doc, &mut iter)?;
    drop(iter);
    let plots = if want_plots {
        write_plots(spec, &light, &opts.out)
    } else {
        Vec::new()
    };
    Ok(RunSummary {
        total,
        in_shard: mine.len() as u64,
        skipped,
        ran,
        not_ok,
        result: opts.out.clone(),
        stream,
        plots,
    })
}

/// Writes the spec's plots of a complete result's variants into its folder: `<name>.svg`.
pub fn write_plots(
    spec: &SweepSpec,
    variants: &[Value],
    out: &Path,
) -> Vec<Result<PathBuf, String>> {
    spec.plots
        .iter()
        .map(|p| {
            let dir = out.parent().unwrap_or(Path::new("."));
            let path = dir.join(format!("{}.svg", p.name));
            let svg =
                super::plots::render(variants, p).map_err(|e| format!("plot `{}`: {e}", p.name))?;
            std::fs::write(&path, svg).map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(path)
        })
        .collect()
}

/// One variant's stream line.
pub(crate) fn variant_line(spec: &SweepSpec, v: &super::expand::Variant, o: Outcome) -> Value {
    let mut m = Map::new();
    m.insert("id".into(), json!(v.id));
    m.insert("params".into(), v.params(spec));
    m.insert("status".into(), json!(o.status));
    if let Some(msg) = o.message {
        m.insert("message".into(), json!(msg));
    }
    if let Some(s) = &o.signals {
        let r = reduce(s, &spec.reductions);
        m.insert(
            "reductions".into(),
            serde_json::to_value(&r).unwrap_or(Value::Null),
        );
        if let Some(series) = kept_series(s, &spec.reductions) {
            m.insert("series".into(), series);
        }
    } else {
        m.insert("reductions".into(), Value::Null);
    }
    if let Some(extra) = o.extra {
        m.insert("sim".into(), extra);
    }
    Value::Object(m)
}

pub(crate) fn result_doc(
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

/// Writes `doc` (whose top-level `variants` is empty) with the variant lines from
/// `variants` (compact JSON, one per line, in order) through a temporary file and a
/// rename. Memory stays independent of the number of variants.
pub(crate) fn write_result_streamed(
    path: &Path,
    doc: &Value,
    variants: &mut dyn Iterator<Item = Result<String, SweepError>>,
) -> Result<(), SweepError> {
    let text = serde_json::to_string_pretty(doc).unwrap_or_default();
    // Top-level keys are indented by two spaces; nested ones by more.
    let marker = "\n  \"variants\": []";
    let at = text
        .find(marker)
        .ok_or_else(|| SweepError::Output("internal: no variants field".into()))?;
    let tmp = path.with_extension("json.tmp");
    let file = File::create(&tmp).map_err(|e| SweepError::io(&tmp, e))?;
    let mut w = std::io::BufWriter::new(file);
    let io = |e| SweepError::io(&tmp, e);
    w.write_all(&text.as_bytes()[..at]).map_err(io)?;
    w.write_all(b"\n  \"variants\": [").map_err(io)?;
    let mut first = true;
    for line in variants {
        let line = line?;
        w.write_all(if first { b"\n    " } else { b",\n    " })
            .map_err(io)?;
        w.write_all(line.as_bytes()).map_err(io)?;
        first = false;
    }
    w.write_all(if first { b"]" } else { b"\n  ]" })
        .map_err(io)?;
    w.write_all(&text.as_bytes()[at + marker.len()..])
        .map_err(io)?;
    w.write_all(b"\n").map_err(io)?;
    w.flush().map_err(io)?;
    drop(w);
    std::fs::rename(&tmp, path).map_err(|e| SweepError::io(path, e))
}

/// Writes `doc` to `path` through a temporary file and a rename (never half a result).
pub fn write_result(path: &Path, doc: &Value) -> Result<(), SweepError> {
    let tmp = path.with_extension("json.tmp");
    let text = serde_json::to_string_pretty(doc).unwrap_or_default();
    std::fs::write(&tmp, text + "\n").map_err(|e| SweepError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| SweepError::io(path, e))
}

/// Peak resident set size of this process (VmHWM), bytes; `None` off Linux.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_and_batch_parsing() {
        assert_eq!(
            "3/16".parse::<Shard>(),
            Ok(Shard {
                index: 3,
                count: 16
            })
        );
        for bad in ["16/16", "1/0", "a/2", "3", "-1/4"] {
            assert!(bad.parse::<Shard>().is_err(), "`{bad}` accepted");
        }
        let s = Shard { index: 1, count: 3 };
        assert_eq!(
            (0..10).filter(|&i| s.owns(i)).collect::<Vec<_>>(),
            vec![1, 4, 7]
        );
        assert_eq!("auto".parse::<BatchSize>(), Ok(BatchSize::Auto));
        assert_eq!("64".parse::<BatchSize>(), Ok(BatchSize::Fixed(64)));
        assert!("0".parse::<BatchSize>().is_err());
    }

    #[test]
    fn fnv_reference_values() {
        // FNV-1a 64 test vectors (Fowler, Noll, Vo): "" and "a".
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn stream_path_replaces_the_extension() {
        assert_eq!(
            stream_path(Path::new("out/r.json")),
            PathBuf::from("out/r.jsonl")
        );
        assert_eq!(stream_path(Path::new("r")), PathBuf::from("r.jsonl"));
    }
}
