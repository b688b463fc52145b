//! The embedded store: one SQLite database (`DIR/sweeps.db`, WAL journal, full sync so a
//! committed variant survives a crash) behind a mutex. Listing and status read the
//! summary columns only; a stored result document is read on its own route.

use std::path::Path;
use std::sync::Mutex;

use rusqlite::{params, Connection, OptionalExtension};
use serde_json::Value;

use super::store::{NewSweep, Store, StoreError, SweepRow, SweepStatus, SweepUpdate};
use crate::sweep::sink::Committed;

/// Wait for a busy database (another process holding a write lock), ms.
const BUSY_TIMEOUT_MS: u64 = 5_000;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS sweeps (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT NOT NULL UNIQUE,
    name TEXT NOT NULL,
    status TEXT NOT NULL,
    spec TEXT NOT NULL,
    options TEXT NOT NULL,
    total INTEGER NOT NULL,
    done INTEGER NOT NULL DEFAULT 0,
    failed INTEGER NOT NULL DEFAULT 0,
    computed INTEGER NOT NULL DEFAULT 0,
    message TEXT,
    header TEXT,
    run TEXT,
    result_doc TEXT,
    created REAL NOT NULL,
    started REAL,
    finished REAL
);
CREATE TABLE IF NOT EXISTS variants (
    sweep TEXT NOT NULL,
    variant INTEGER NOT NULL,
    ok INTEGER NOT NULL,
    line TEXT NOT NULL,
    PRIMARY KEY (sweep, variant)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS plots (
    sweep TEXT NOT NULL,
    name TEXT NOT NULL,
    svg TEXT NOT NULL,
    PRIMARY KEY (sweep, name)
) WITHOUT ROWID;
";

/// The SQLite store.
pub struct SqliteStore {
    conn: Mutex<Connection>,
}

impl SqliteStore {
    /// Opens (creating) `dir/sweeps.db`. Every failure names the file and the reason
    /// (e.g. a read-only folder or file, a file that is not a database).
    pub fn open(dir: &Path) -> Result<Self, StoreError> {
        std::fs::create_dir_all(dir).map_err(|e| {
            StoreError::Backend(format!(
                "store folder {}: cannot create it: {e}",
                dir.display()
            ))
        })?;
        let path = dir.join("sweeps.db");
        let fail = |e: &dyn std::fmt::Display| {
            StoreError::Backend(format!(
                "{}: {e}{}",
                path.display(),
                why_unwritable(dir, &path)
            ))
        };
        let conn = Connection::open(&path).map_err(|e| fail(&e))?;
        conn.busy_timeout(std::time::Duration::from_millis(BUSY_TIMEOUT_MS))
            .map_err(|e| fail(&e))?;
        let mode: String = conn
            .query_row("PRAGMA journal_mode=WAL", [], |r| r.get(0))
            .map_err(|e| fail(&e))?;
        if !mode.eq_ignore_ascii_case("wal") {
            return Err(StoreError::Backend(format!(
                "{}: cannot switch to WAL mode (got {mode}){}",
                path.display(),
                why_unwritable(dir, &path)
            )));
        }
        conn.execute_batch("PRAGMA synchronous=FULL; PRAGMA foreign_keys=ON;")
            .and_then(|_| conn.execute_batch(SCHEMA))
            .map_err(|e| fail(&e))?;
        Ok(SqliteStore {
            conn: Mutex::new(conn),
        })
    }

    fn with<T>(
        &self,
        f: impl FnOnce(&mut Connection) -> rusqlite::Result<T>,
    ) -> Result<T, StoreError> {
        let mut conn = self
            .conn
            .lock()
            .map_err(|_| StoreError::Backend("store lock poisoned".into()))?;
        f(&mut conn).map_err(classify)
    }
}

/// The reason SQLite's own message leaves out ("unable to open database file"): whether
/// the file and its folder (where the WAL and shared-memory files go) can be written,
/// with the operating system's words; empty when both can.
fn why_unwritable(dir: &Path, file: &Path) -> String {
    if file.exists() {
        if let Err(e) = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(file)
        {
            return format!(" (the file cannot be opened for writing: {e})");
        }
    }
    let probe = dir.join(format!(".write-probe-{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            String::new()
        }
        Err(e) => format!(
            " (its folder {} cannot be written, and SQLite keeps its journal beside the file: {e})",
            dir.display()
        ),
    }
}

/// A database error as a store error: a full disk, a busy database or an I/O error may
/// pass (503 with `Retry-After`); anything else is a fault.
fn classify(e: rusqlite::Error) -> StoreError {
    use rusqlite::ErrorCode as C;
    match e.sqlite_error_code() {
        Some(C::DiskFull | C::DatabaseBusy | C::DatabaseLocked | C::SystemIoFailure) => {
            StoreError::Unavailable(e.to_string())
        }
        _ => StoreError::Backend(e.to_string()),
    }
}

/// The summary columns: everything but the spec, the stream header and a stored result
/// document (which may be large: listing and status read these only).
const SUMMARY: &str = "id, seq, name, status, NULL, options, total, done, failed, computed, message, run, created, started, finished, NULL";
/// Every column a run needs (the spec and the header too).
const COLUMNS: &str = "id, seq, name, status, spec, options, total, done, failed, computed, message, run, created, started, finished, header";

fn json_col(text: Option<String>) -> Option<Value> {
    text.and_then(|t| serde_json::from_str(&t).ok())
}

fn row(r: &rusqlite::Row<'_>) -> rusqlite::Result<SweepRow> {
    let status: String = r.get(3)?;
    Ok(SweepRow {
        id: r.get(0)?,
        seq: r.get(1)?,
        name: r.get(2)?,
        // An unknown stored status (a newer version's) reads as failed, never a panic.
        status: SweepStatus::parse(&status).unwrap_or(SweepStatus::Failed),
        spec: json_col(r.get(4)?).unwrap_or(Value::Null),
        options: json_col(r.get(5)?).unwrap_or(Value::Null),
        total: r.get::<_, i64>(6)? as u64,
        done: r.get::<_, i64>(7)? as u64,
        failed: r.get::<_, i64>(8)? as u64,
        computed: r.get::<_, i64>(9)? as u64,
        message: r.get(10)?,
        run: json_col(r.get(11)?),
        created_unix_s: r.get(12)?,
        started_unix_s: r.get(13)?,
        finished_unix_s: r.get(14)?,
        header: json_col(r.get(15)?),
    })
}

impl Store for SqliteStore {
    fn insert_sweep(&self, new: &NewSweep) -> Result<SweepRow, StoreError> {
        self.insert_sweep_limited(new, u64::MAX)
    }

    fn insert_sweep_limited(&self, new: &NewSweep, max_open: u64) -> Result<SweepRow, StoreError> {
        // Counted and inserted in one immediate (write-locked) transaction: two servers
        // or threads cannot both see room for one more.
        let open = self.with(|c| {
            let tx = c.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)?;
            let open: i64 = tx.query_row(
                "SELECT count(*) FROM sweeps WHERE status IN ('queued', 'running')",
                [],
                |r| r.get(0),
            )?;
            if open as u64 >= max_open {
                return Ok(Some(open as u64));
            }
            tx.execute(
                "INSERT INTO sweeps (id, name, status, spec, options, total, created) VALUES (?1, ?2, 'queued', ?3, ?4, ?5, ?6)",
                params![
                    new.id,
                    new.name,
                    new.spec.to_string(),
                    new.options.to_string(),
                    new.total as i64,
                    new.created_unix_s
                ],
            )?;
            tx.commit()?;
            Ok(None)
        })?;
        if let Some(open) = open {
            return Err(StoreError::QueueFull {
                open,
                limit: max_open,
            });
        }
        self.sweep_summary(&new.id)?
            .ok_or_else(|| StoreError::NotFound(new.id.clone()))
    }

    fn list_sweeps(&self) -> Result<Vec<SweepRow>, StoreError> {
        self.with(|c| {
            let mut st = c.prepare(&format!("SELECT {SUMMARY} FROM sweeps ORDER BY seq"))?;
            let rows = st.query_map([], row)?;
            rows.collect()
        })
    }

    fn count_queued(&self) -> Result<u64, StoreError> {
        self.with(|c| {
            c.query_row(
                "SELECT count(*) FROM sweeps WHERE status = 'queued'",
                [],
                |r| r.get::<_, i64>(0),
            )
        })
        .map(|n| n as u64)
    }

    fn sweep_summary(&self, id: &str) -> Result<Option<SweepRow>, StoreError> {
        self.with(|c| {
            c.query_row(
                &format!("SELECT {SUMMARY} FROM sweeps WHERE id = ?1"),
                [id],
                row,
            )
            .optional()
        })
    }

    fn result_doc_text(&self, id: &str) -> Result<Option<String>, StoreError> {
        self.with(|c| {
            c.query_row("SELECT result_doc FROM sweeps WHERE id = ?1", [id], |r| {
                r.get::<_, Option<String>>(0)
            })
            .optional()
            .map(Option::flatten)
        })
    }

    fn sweep(&self, id: &str) -> Result<Option<SweepRow>, StoreError> {
        self.with(|c| {
            c.query_row(
                &format!("SELECT {COLUMNS} FROM sweeps WHERE id = ?1"),
                [id],
                row,
            )
            .optional()
        })
    }

    fn update_sweep(&self, id: &str, change: &SweepUpdate) -> Result<(), StoreError> {
        let n = self.with(|c| {
            let tx = c.transaction()?;
            let mut n = tx.execute("UPDATE sweeps SET seq = seq WHERE id = ?1", [id])?;
            if let Some(s) = change.status {
                n = tx.execute(
                    "UPDATE sweeps SET status = ?2 WHERE id = ?1",
                    params![id, s.name()],
                )?;
            }
            if let Some(m) = &change.message {
                tx.execute(
                    "UPDATE sweeps SET message = ?2 WHERE id = ?1",
                    params![id, m],
                )?;
            }
            if let Some(r) = &change.run {
                tx.execute(
                    "UPDATE sweeps SET run = ?2 WHERE id = ?1",
                    params![id, r.to_string()],
                )?;
            }
            if let Some(d) = &change.result_doc {
                tx.execute(
                    "UPDATE sweeps SET result_doc = ?2 WHERE id = ?1",
                    params![id, d],
                )?;
            }
            if let Some(t) = change.started_unix_s {
                tx.execute(
                    "UPDATE sweeps SET started = ?2 WHERE id = ?1",
                    params![id, t],
                )?;
            }
            if let Some(t) = change.finished_unix_s {
                tx.execute(
                    "UPDATE sweeps SET finished = ?2 WHERE id = ?1",
                    params![id, t],
                )?;
            }
            if let Some(d) = change.done {
                tx.execute(
                    "UPDATE sweeps SET done = ?2, computed = ?2 WHERE id = ?1",
                    params![id, d as i64],
                )?;
            }
            tx.commit()?;
            Ok(n)
        })?;
        if n == 0 {
            return Err(StoreError::NotFound(id.to_string()));
        }
        Ok(())
    }

    fn delete_sweep(&self, id: &str) -> Result<bool, StoreError> {
        self.with(|c| {
            let tx = c.transaction()?;
            tx.execute("DELETE FROM variants WHERE sweep = ?1", [id])?;
            tx.execute("DELETE FROM plots WHERE sweep = ?1", [id])?;
            let n = tx.execute("DELETE FROM sweeps WHERE id = ?1", [id])?;
            tx.commit()?;
            Ok(n > 0)
        })
    }

    fn open_stream(&self, id: &str, header: &Value) -> Result<Committed, StoreError> {
        let text = header.to_string();
        let stored: Option<Option<String>> = self.with(|c| {
            c.query_row("SELECT header FROM sweeps WHERE id = ?1", [id], |r| {
                r.get(0)
            })
            .optional()
        })?;
        match stored {
            None => return Err(StoreError::NotFound(id.to_string())),
            Some(None) => {
                self.with(|c| {
                    c.execute(
                        "UPDATE sweeps SET header = ?2 WHERE id = ?1",
                        params![id, text],
                    )
                })?;
            }
            Some(Some(h)) => {
                let old: Value = serde_json::from_str(&h).unwrap_or(Value::Null);
                if &old != header {
                    return Err(StoreError::Mismatch {
                        id: id.to_string(),
                        reason: format!("stored header {old}, this run {header}"),
                    });
                }
            }
        }
        self.with(|c| {
            let mut st =
                c.prepare("SELECT variant, ok FROM variants WHERE sweep = ?1 ORDER BY variant")?;
            let rows = st.query_map([id], |r| Ok((r.get::<_, i64>(0)? as u64, r.get(1)?)))?;
            rows.collect()
        })
    }

    fn commit_variant(
        &self,
        id: &str,
        variant: u64,
        ok: bool,
        line: &str,
    ) -> Result<(), StoreError> {
        let found = self.with(|c| {
            let tx = c.transaction()?;
            let new = tx.execute(
                "INSERT OR IGNORE INTO variants (sweep, variant, ok, line) VALUES (?1, ?2, ?3, ?4)",
                params![id, variant as i64, ok, line],
            )?;
            // `computed` counts every commit, `done` only new lines: they differ exactly
            // when a finished variant was computed again.
            let found = tx.execute(
                "UPDATE sweeps SET computed = computed + 1, done = done + ?2, failed = failed + ?3 WHERE id = ?1",
                params![id, new as i64, (new > 0 && !ok) as i64],
            )?;
            // A sweep deleted meanwhile keeps no orphan lines (the transaction is dropped).
            if found > 0 {
                tx.commit()?;
            }
            Ok(found > 0)
        })?;
        if !found {
            return Err(StoreError::NotFound(id.to_string()));
        }
        Ok(())
    }

    fn variant_lines(
        &self,
        id: &str,
        offset: u64,
        limit: u64,
    ) -> Result<Vec<(u64, String)>, StoreError> {
        self.with(|c| {
            let mut st = c.prepare(
                "SELECT variant, line FROM variants WHERE sweep = ?1 ORDER BY variant LIMIT ?2 OFFSET ?3",
            )?;
            let rows = st.query_map(
                params![id, limit.min(i64::MAX as u64) as i64, offset.min(i64::MAX as u64) as i64],
                |r| Ok((r.get::<_, i64>(0)? as u64, r.get(1)?)),
            )?;
            rows.collect()
        })
    }

    fn put_plot(&self, id: &str, name: &str, svg: &str) -> Result<(), StoreError> {
        self.with(|c| {
            c.execute(
                "INSERT OR REPLACE INTO plots (sweep, name, svg) VALUES (?1, ?2, ?3)",
                params![id, name, svg],
            )?;
            Ok(())
        })
    }

    fn plot(&self, id: &str, name: &str) -> Result<Option<String>, StoreError> {
        self.with(|c| {
            c.query_row(
                "SELECT svg FROM plots WHERE sweep = ?1 AND name = ?2",
                [id, name],
                |r| r.get(0),
            )
            .optional()
        })
    }

    fn plot_names(&self, id: &str) -> Result<Vec<String>, StoreError> {
        self.with(|c| {
            let mut st = c.prepare("SELECT name FROM plots WHERE sweep = ?1 ORDER BY name")?;
            let rows = st.query_map([id], |r| r.get(0))?;
            rows.collect()
        })
    }
}
