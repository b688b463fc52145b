//! Errors of the PostgreSQL store and queue, layered: what the store was doing, then the
//! database's or the pool's own error.

/// A failure of the PostgreSQL store, queue or worker.
#[derive(Debug, thiserror::Error)]
pub enum PgError {
    /// The `--database` URL does not parse (the message never repeats a password).
    #[error("--database: {0}")]
    Url(String),
    /// A statement failed or the connection broke while doing `context`.
    #[error("PostgreSQL at {target}, {context}: {source}")]
    Db {
        /// Host, port and database (no credentials).
        target: String,
        /// What the store was doing, e.g. `claiming a batch`.
        context: &'static str,
        /// The client's error (a database error carries its SQLSTATE).
        #[source]
        source: tokio_postgres::Error,
    },
    /// No connection could be had from the pool (server down, pool closed, timeout).
    #[error("PostgreSQL at {target}, {context}: no connection ({reason})")]
    Pool {
        /// Host, port and database (no credentials).
        target: String,
        /// What the store was doing.
        context: &'static str,
        /// The pool's reason.
        reason: String,
    },
    /// A schema migration failed (the transaction rolled back; nothing was applied).
    #[error("PostgreSQL schema migration {version} ({name}): {source}")]
    Migration {
        /// Migration number.
        version: i32,
        /// Migration name.
        name: &'static str,
        /// The database's error.
        #[source]
        source: tokio_postgres::Error,
    },
    /// The database was migrated by a newer bearing-sweep.
    #[error("the database schema is at version {found}, newer than this program's {known}; upgrade bearing-sweep on this machine")]
    SchemaTooNew {
        /// Version found in `schema_migrations`.
        found: i32,
        /// Newest version this program knows.
        known: i32,
    },
    /// A submitted spec is invalid (the JSON path and the reason).
    #[error(transparent)]
    Spec(crate::sweep::SweepError),
    /// No sweep with this id.
    #[error("sweep `{0}` not found")]
    NotFound(String),
    /// A sweep stored in the database cannot be run or read (bad spec, settings clash).
    #[error("sweep `{id}`: {reason}")]
    Sweep {
        /// Sweep id.
        id: String,
        /// What is wrong.
        reason: String,
    },
}

impl PgError {
    /// Whether retrying later may succeed: the connection broke, the server is starting
    /// or shutting down, the pool had no connection, or a serialization conflict.
    /// Everything else (bad SQL, a constraint, bad input) is permanent.
    pub fn is_transient(&self) -> bool {
        match self {
            PgError::Pool { .. } => true,
            PgError::Db { source, .. } => is_transient_db(source),
            _ => false,
        }
    }
}

/// Connection-level failures of the client: closed connection, I/O, or SQLSTATE classes
/// 08 (connection exception), 57P (operator intervention: shutdown, cannot connect now),
/// 40001/40P01 (serialization failure, deadlock: retry the transaction).
pub(crate) fn is_transient_db(e: &tokio_postgres::Error) -> bool {
    if e.is_closed() {
        return true;
    }
    match e.code() {
        Some(code) => {
            let c = code.code();
            c.starts_with("08") || c.starts_with("57P") || c == "40001" || c == "40P01"
        }
        // No SQLSTATE: an I/O or protocol error of the connection itself, unless it is
        // a type conversion of a parameter or a column (a bug, not worth retrying).
        None => {
            let msg = e.to_string();
            !(msg.contains("serializing") || msg.contains("column") || msg.contains("parameters"))
        }
    }
}
