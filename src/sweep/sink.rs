//! Where the runner puts finished variants: the [`VariantSink`] trait (resume, commit,
//! read back in id order) that the result.jsonl folder ([`super::folder_sink::FolderSink`])
//! and the service's store implement, so `run` and the service share one runner and one
//! resume logic.

use std::collections::BTreeMap;

use serde_json::Value;

use super::SweepError;

/// A finished variant already in a sink: whether its status is `ok`.
pub type Committed = BTreeMap<u64, bool>;

/// Storage of one run's finished variants (one JSON line each).
///
/// Contract: a line passed to [`VariantSink::commit`] survives the process being killed
/// once `commit` returns (the runner reports a variant only after that); a run opened
/// again with the same header resumes from what was committed; lines come back
/// byte-identical.
pub trait VariantSink {
    /// Opens the sink for the run that `header` identifies (format, spec hash, settings,
    /// shard, count). Returns the variants already committed by an earlier run with the
    /// same header (id → status is `ok`); refuses (naming why) what another spec,
    /// settings or shard wrote.
    fn open(&mut self, header: &Value) -> Result<Committed, SweepError>;

    /// Stores one finished variant's line (compact JSON, no newline).
    fn commit(&mut self, id: u64, ok: bool, line: &str) -> Result<(), SweepError>;

    /// End of a batch: make everything committed so far durable (e.g. fsync).
    fn checkpoint(&mut self) -> Result<(), SweepError> {
        Ok(())
    }

    /// Calls `f(id, line)` for every committed variant, in id order.
    fn for_each_line(
        &mut self,
        f: &mut dyn FnMut(u64, &str) -> Result<(), SweepError>,
    ) -> Result<(), SweepError>;
}

/// A sink in memory (tests, small in-process runs). Never durable.
#[derive(Clone, Debug, Default)]
pub struct MemorySink {
    /// The header it was opened with.
    pub header: Option<Value>,
    /// Committed lines by id: (status is `ok`, line).
    pub lines: BTreeMap<u64, (bool, String)>,
}

impl VariantSink for MemorySink {
    fn open(&mut self, header: &Value) -> Result<Committed, SweepError> {
        match &self.header {
            Some(h) if h != header => {
                return Err(SweepError::Output(format!(
                    "in-memory sink: written by another run (its header {h}, this run {header})"
                )))
            }
            _ => self.header = Some(header.clone()),
        }
        Ok(self.lines.iter().map(|(id, (ok, _))| (*id, *ok)).collect())
    }

    fn commit(&mut self, id: u64, ok: bool, line: &str) -> Result<(), SweepError> {
        self.lines.entry(id).or_insert((ok, line.to_string()));
        Ok(())
    }

    fn for_each_line(
        &mut self,
        f: &mut dyn FnMut(u64, &str) -> Result<(), SweepError>,
    ) -> Result<(), SweepError> {
        self.lines.iter().try_for_each(|(id, (_, l))| f(*id, l))
    }
}
