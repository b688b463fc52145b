//! The result.jsonl stream of `run` as a [`VariantSink`]: for `--out …/result.json`, the
//! stream `result.jsonl` (first line a header naming the spec hash, settings and shard;
//! then one variant per line, each written with one call and flushed, so a kill leaves at
//! most one torn last line, which a resume drops) and an advisory lock `result.lock`
//! holding the running process's id, so that a second run into the same folder refuses
//! instead of corrupting the stream. The lock file is removed when the sink is dropped
//! (a finished or stopped run); only a killed process leaves it, and the next run takes
//! it over (the lock itself died with the process).

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::sink::{Committed, VariantSink};
use super::SweepError;

/// Format tag of a stream header.
pub const STREAM_FORMAT: &str = "bearing-sweep/sweep-stream/1";

/// Hex digits of the FNV-1a 64 spec hash that versions before the sha2-256 one wrote.
const OLD_HASH_HEX_DIGITS: usize = 16;

/// The stream path for result path `out`: extension replaced by `jsonl`.
pub fn stream_path(out: &Path) -> PathBuf {
    out.with_extension("jsonl")
}

/// The lock file for result path `out`: extension replaced by `lock`.
pub fn lock_path(out: &Path) -> PathBuf {
    out.with_extension("lock")
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

/// The stream file of one result, locked for this process while the sink lives.
pub struct FolderSink {
    result: PathBuf,
    stream: PathBuf,
    /// Held for the sink's lifetime: the advisory lock (released when dropped).
    _lock: File,
    file: Option<File>,
    /// Byte length of the stream's intact part (where the next line goes).
    len: u64,
    lines: BTreeMap<u64, LineRef>,
}

impl FolderSink {
    /// Prepares the folder of result file `result` (created if missing): refuses when
    /// `result` is a directory, and takes the folder's lock, refusing (with the holder's
    /// pid) when another run holds it. Nothing else is touched until [`VariantSink::open`].
    pub fn new(result: &Path) -> Result<Self, SweepError> {
        if result.is_dir() {
            return Err(SweepError::Output(format!(
                "{}: is a directory, so the result cannot be written there; move it away or use another --out",
                result.display()
            )));
        }
        if let Some(dir) = result.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| SweepError::io(dir, e))?;
        }
        let lock = take_lock(&lock_path(result))?;
        Ok(FolderSink {
            result: result.to_path_buf(),
            stream: stream_path(result),
            _lock: lock,
            file: None,
            len: 0,
            lines: BTreeMap::new(),
        })
    }

    /// The stream file.
    pub fn stream(&self) -> &Path {
        &self.stream
    }

    /// The result file this sink belongs to.
    pub fn result(&self) -> &Path {
        &self.result
    }

    fn io(&self, e: std::io::Error) -> SweepError {
        SweepError::io(&self.stream, e)
    }
}

/// Takes the advisory lock at `path` and writes this process's id into it. A run that
/// finishes removes the file while holding the lock, so a second process may have opened
/// the old file and locked it after that: it then holds a lock on a removed file, and it
/// tries again on the path's current file.
fn take_lock(path: &Path) -> Result<File, SweepError> {
    // Each retry follows a removal by a run that just finished: a few suffice.
    const ATTEMPTS: usize = 8;
    let mut last = None;
    for _ in 0..ATTEMPTS {
        let f = take_lock_once(path)?;
        if same_file(&f, path) {
            return Ok(f);
        }
        last = Some(f);
    }
    last.ok_or_else(|| SweepError::Output(format!("{}: cannot take the lock", path.display())))
}

/// Whether `f` is still the file at `path` (not one removed after `f` was opened).
fn same_file(f: &File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (f.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (f, path);
        true
    }
}

fn take_lock_once(path: &Path) -> Result<File, SweepError> {
    let mut f = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .map_err(|e| SweepError::io(path, e))?;
    match f.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = f.read_to_string(&mut holder);
            let holder = holder.trim();
            let who = if holder.is_empty() {
                "another process".to_string()
            } else {
                format!("process {holder}")
            };
            return Err(SweepError::Output(format!(
                "{}: the output folder is in use by {who} (another `run` with the same --out); wait for it or use another --out",
                path.display()
            )));
        }
        Err(std::fs::TryLockError::Error(e)) => return Err(SweepError::io(path, e)),
    }
    let pid = std::process::id();
    f.set_len(0)
        .and_then(|_| f.seek(SeekFrom::Start(0)))
        .and_then(|_| writeln!(f, "{pid}"))
        .and_then(|_| f.flush())
        .map_err(|e| SweepError::io(path, e))?;
    Ok(f)
}

impl VariantSink for FolderSink {
    fn open(&mut self, header: &Value) -> Result<Committed, SweepError> {
        let (lines, good_len) = if self.stream.exists() {
            read_stream(&self.stream, header)?
        } else {
            (BTreeMap::new(), 0)
        };
        let mut f = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&self.stream)
            .map_err(|e| self.io(e))?;
        // Drop a torn last line (a kill in mid-write).
        f.set_len(good_len).map_err(|e| self.io(e))?;
        f.seek(SeekFrom::End(0)).map_err(|e| self.io(e))?;
        let mut len = good_len;
        if good_len == 0 {
            let line = format!("{header}\n");
            f.write_all(line.as_bytes()).map_err(|e| self.io(e))?;
            len = line.len() as u64;
        }
        f.flush().map_err(|e| self.io(e))?;
        self.file = Some(f);
        self.len = len;
        self.lines = lines;
        Ok(self.lines.iter().map(|(id, l)| (*id, l.ok)).collect())
    }

    fn commit(&mut self, id: u64, ok: bool, line: &str) -> Result<(), SweepError> {
        let stream = self.stream.clone();
        let file = self
            .file
            .as_mut()
            .ok_or_else(|| SweepError::Output("internal: sink not opened".into()))?;
        // One write call per line: a kill leaves at most one torn last line.
        let mut bytes = Vec::with_capacity(line.len() + 1);
        bytes.extend_from_slice(line.as_bytes());
        bytes.push(b'\n');
        file.write_all(&bytes)
            .and_then(|_| file.flush())
            .map_err(|e| SweepError::io(&stream, e))?;
        self.lines.entry(id).or_insert(LineRef {
            offset: self.len,
            len: line.len(),
            ok,
        });
        self.len += bytes.len() as u64;
        Ok(())
    }

    fn checkpoint(&mut self) -> Result<(), SweepError> {
        if let Some(f) = &self.file {
            f.sync_data().map_err(|e| SweepError::io(&self.stream, e))?;
        }
        Ok(())
    }

    fn for_each_line(
        &mut self,
        f: &mut dyn FnMut(u64, &str) -> Result<(), SweepError>,
    ) -> Result<(), SweepError> {
        let mut reader = File::open(&self.stream).map_err(|e| self.io(e))?;
        let mut buf = Vec::new();
        for (id, r) in &self.lines {
            buf.resize(r.len, 0);
            reader
                .seek(SeekFrom::Start(r.offset))
                .and_then(|_| reader.read_exact(&mut buf))
                .map_err(|e| SweepError::io(&self.stream, e))?;
            f(*id, &String::from_utf8_lossy(&buf))?;
        }
        Ok(())
    }
}

impl Drop for FolderSink {
    fn drop(&mut self) {
        // Durable at the end too (errors were reported by the last checkpoint).
        if let Some(f) = &self.file {
            let _ = f.sync_all();
        }
        // `result.lock` goes while its lock is still held (the handle closes after this),
        // so a finished folder holds only its results.
        let _ = std::fs::remove_file(lock_path(&self.result));
    }
}

/// Reads an existing stream: checks its header against `expected`, returns where each
/// finished variant's line is (first occurrence per id), and the byte length of its
/// intact prefix (a torn last line, left by a kill in mid-write, is excluded). Memory: a
/// few words per variant, whatever the lines hold.
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
            let _ = reader.read_to_end(&mut rest);
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
            check_header(path, &v, expected)?;
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

/// A stream's header must equal this run's; an older version's hash gets its own message.
fn check_header(path: &Path, found: &Value, expected: &Value) -> Result<(), SweepError> {
    if found.get("format").and_then(Value::as_str) != Some(STREAM_FORMAT) {
        return Err(SweepError::Output(format!(
            "{}: not a bearing-sweep stream (first line has no format `{STREAM_FORMAT}`)",
            path.display()
        )));
    }
    let old_hash = found
        .get("spec_hash")
        .and_then(Value::as_str)
        .is_some_and(|h| h.len() == OLD_HASH_HEX_DIGITS);
    if old_hash {
        return Err(SweepError::Output(format!(
            "{}: written by an older version of bearing-sweep (16-digit FNV-1a spec hash; specs are now identified by sha2-256), so it cannot be resumed safely; move it away to start over",
            path.display()
        )));
    }
    if found != expected {
        let mut diffs = Vec::new();
        differing_keys("", found, expected, &mut diffs);
        let listed: Vec<String> = diffs
            .iter()
            .map(|(key, was, now)| {
                let flag = flag_of(key).map_or(String::new(), |f| format!(" ({f})"));
                format!("`{key}`{flag}: folder {was}, this run {now}")
            })
            .collect();
        let dir = path.parent().unwrap_or(Path::new("."));
        return Err(SweepError::Output(format!(
            "{}: this folder holds a run with a different spec, settings or shard, so it cannot be resumed: {}. To keep both, give this run another --out; to start over, delete {}; to resume the folder's run, repeat its flags",
            path.display(),
            crate::json::shorten(&listed.join("; "), 1200),
            dir.display()
        )));
    }
    Ok(())
}

/// The leaf keys (dotted paths) where `a` and `b` differ, with both values (a key missing
/// on one side reads `none`).
fn differing_keys(prefix: &str, a: &Value, b: &Value, out: &mut Vec<(String, String, String)>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => differing_keys(&p, u, v, out),
                    (u, v) => out.push((p, shown(u), shown(v))),
                }
            }
        }
        _ if a != b => out.push((prefix.to_string(), shown(Some(a)), shown(Some(b)))),
        _ => {}
    }
}

fn shown(v: Option<&Value>) -> String {
    match v {
        None => "none".into(),
        Some(v) => crate::json::shorten(&v.to_string(), 80),
    }
}

/// The command-line flag or input behind a header key, where one is.
fn flag_of(key: &str) -> Option<&'static str> {
    let leaf = key.rsplit('.').next().unwrap_or(key);
    Some(match leaf {
        "spec_hash" | "count" => "the spec file changed",
        "shard" | "index" if key.starts_with("shard") => "--shard",
        "backend" | "precision" | "device" => "--backend",
        "film_accuracy" | "accuracy" => "--accuracy",
        "full_model" => "--full-model",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "bearing-sweep-folder-sink-{}-{name}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn header(hash: &str) -> Value {
        json!({"format": STREAM_FORMAT, "spec_hash": hash, "settings": {}, "shard": null, "count": 3})
    }

    #[test]
    fn a_second_sink_on_the_same_folder_refuses_and_names_the_holder() {
        let out = scratch("lock").join("result.json");
        let first = FolderSink::new(&out).unwrap();
        let err = FolderSink::new(&out).err().expect("second lock taken");
        let msg = err.to_string();
        let pid = std::process::id().to_string();
        assert!(
            msg.contains(&format!("process {pid}")) && msg.contains("in use"),
            "message {msg:?} should name pid {pid}"
        );
        drop(first);
        // Released with the first sink.
        FolderSink::new(&out).unwrap();
    }

    #[test]
    fn a_directory_in_place_of_the_result_is_refused_before_anything_runs() {
        let out = scratch("dir").join("result.json");
        std::fs::create_dir_all(&out).unwrap();
        let msg = FolderSink::new(&out).err().unwrap().to_string();
        assert!(msg.contains("is a directory"), "{msg}");
        assert!(
            !stream_path(&out).exists(),
            "stream created despite the error"
        );
    }

    #[test]
    fn commits_resume_byte_identical_and_a_torn_line_is_dropped() {
        let out = scratch("resume").join("result.json");
        let h = header(&"ab".repeat(32));
        {
            let mut s = FolderSink::new(&out).unwrap();
            assert!(s.open(&h).unwrap().is_empty());
            s.commit(2, true, r#"{"id":2,"status":"ok"}"#).unwrap();
            s.commit(0, false, r#"{"id":0,"status":"failed"}"#).unwrap();
            s.checkpoint().unwrap();
        }
        // A kill in mid-write leaves a torn last line.
        let mut f = OpenOptions::new()
            .append(true)
            .open(stream_path(&out))
            .unwrap();
        f.write_all(br#"{"id":1,"sta"#).unwrap();
        drop(f);
        let mut s = FolderSink::new(&out).unwrap();
        let done = s.open(&h).unwrap();
        assert_eq!(done, BTreeMap::from([(0, false), (2, true)]));
        s.commit(1, true, r#"{"id":1,"status":"ok"}"#).unwrap();
        let mut got = Vec::new();
        s.for_each_line(&mut |id, l| {
            got.push((id, l.to_string()));
            Ok(())
        })
        .unwrap();
        let want = [
            (0, r#"{"id":0,"status":"failed"}"#),
            (1, r#"{"id":1,"status":"ok"}"#),
            (2, r#"{"id":2,"status":"ok"}"#),
        ];
        assert_eq!(got.len(), want.len(), "{got:?}");
        for (k, (g, w)) in got.iter().zip(want).enumerate() {
            assert_eq!((g.0, g.1.as_str()), w, "line {k}");
        }
    }

    #[test]
    fn a_stream_with_the_old_fnv_hash_is_refused_with_a_clear_message() {
        let out = scratch("old").join("result.json");
        let old = header("0123456789abcdef");
        std::fs::write(
            stream_path(&out),
            format!("{old}\n{{\"id\":0,\"status\":\"ok\"}}\n"),
        )
        .unwrap();
        let mut s = FolderSink::new(&out).unwrap();
        let msg = s.open(&header(&"cd".repeat(32))).err().unwrap().to_string();
        assert!(
            msg.contains("older version") && msg.contains("move it away"),
            "{msg}"
        );
        // Left as it was.
        let text = std::fs::read_to_string(stream_path(&out)).unwrap();
        assert!(text.contains("0123456789abcdef"), "{text}");
    }
}
