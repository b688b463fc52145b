//! Versioned schema migrations, compiled into the binary and run at start: each runs
//! once, in order, inside one transaction holding an advisory lock (so servers and
//! workers starting together do not race), and is recorded in `schema_migrations`.

use tokio_postgres::Client;

use super::error::PgError;

/// One schema step.
#[derive(Clone, Copy, Debug)]
pub struct Migration {
    /// Version, 1, 2, ... in order.
    pub version: i32,
    /// Short name.
    pub name: &'static str,
    /// The SQL (several statements).
    pub sql: &'static str,
}

/// Every migration this program knows, oldest first.
pub const MIGRATIONS: &[Migration] = &[
    Migration {
        version: 1,
        name: "queue",
        sql: include_str!("migrations/0001_queue.sql"),
    },
    Migration {
        version: 2,
        name: "service",
        sql: include_str!("migrations/0002_service.sql"),
    },
    Migration {
        version: 3,
        name: "lease counts",
        sql: include_str!("migrations/0003_lease_counts.sql"),
    },
    Migration {
        version: 4,
        name: "batch expiry",
        sql: include_str!("migrations/0004_batch_expiry.sql"),
    },
];

/// Advisory lock key of the migrations ("bsweepmg" as eight ASCII bytes).
const MIGRATION_LOCK: i64 = 0x6273_7765_6570_6d67;

/// Brings the schema up to date; returns the versions applied now (empty when it was
/// current). Refuses a database migrated by a newer program.
pub async fn migrate(client: &mut Client, target: &str) -> Result<Vec<i32>, PgError> {
    let db = |context: &'static str| {
        let target = target.to_string();
        move |source| PgError::Db {
            target,
            context,
            source,
        }
    };
    let tx = client
        .transaction()
        .await
        .map_err(db("starting the migrations"))?;
    tx.execute("SELECT pg_advisory_xact_lock($1)", &[&MIGRATION_LOCK])
        .await
        .map_err(db("locking the migrations"))?;
    tx.batch_execute(
        "CREATE TABLE IF NOT EXISTS schema_migrations (
             version    INTEGER PRIMARY KEY,
             name       TEXT NOT NULL,
             applied_at TIMESTAMPTZ NOT NULL DEFAULT now())",
    )
    .await
    .map_err(db("creating schema_migrations"))?;
    let applied: Vec<i32> = tx
        .query(
            "SELECT version FROM schema_migrations ORDER BY version",
            &[],
        )
        .await
        .map_err(db("reading schema_migrations"))?
        .iter()
        .map(|r| r.get(0))
        .collect();
    let known = MIGRATIONS.last().map_or(0, |m| m.version);
    if let Some(&found) = applied.iter().max() {
        if found > known {
            return Err(PgError::SchemaTooNew { found, known });
        }
    }
    let mut now = Vec::new();
    for m in MIGRATIONS.iter().filter(|m| !applied.contains(&m.version)) {
        tx.batch_execute(m.sql)
            .await
            .map_err(|source| PgError::Migration {
                version: m.version,
                name: m.name,
                source,
            })?;
        tx.execute(
            "INSERT INTO schema_migrations (version, name) VALUES ($1, $2)",
            &[&m.version, &m.name],
        )
        .await
        .map_err(db("recording a migration"))?;
        now.push(m.version);
    }
    tx.commit().await.map_err(db("committing the migrations"))?;
    Ok(now)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_are_consecutive_from_one() {
        for (k, m) in MIGRATIONS.iter().enumerate() {
            assert_eq!(m.version, k as i32 + 1, "migration {} ({})", k, m.name);
            assert!(!m.sql.trim().is_empty(), "migration {} is empty", m.version);
        }
    }
}
