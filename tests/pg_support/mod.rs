//! A throwaway PostgreSQL cluster for tests: finds Debian's (or any) PostgreSQL binaries,
//! `initdb`s a temporary folder, starts `postgres` on 127.0.0.1 with an ephemeral port as
//! a non-root user (PostgreSQL refuses to run as root: as root the server runs as the
//! `postgres` user through `runuser`), hands out a connection URL, restarts it on request
//! and stops it and removes its folder when dropped.
//!
//! Without PostgreSQL binaries [`PgCluster::start_or_skip`] prints a notice and returns
//! `None` (the test then passes as skipped), unless `BEARING_SWEEP_REQUIRE_POSTGRES=1`,
//! which turns the missing server into a failure (`.ci/run` sets it).
#![allow(dead_code)] // each test crate uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

/// Environment variable that makes a missing PostgreSQL a test failure.
pub const REQUIRE_ENV: &str = "BEARING_SWEEP_REQUIRE_POSTGRES";
/// Environment variable naming the folder of `initdb`, `pg_ctl` and `postgres`.
pub const BIN_ENV: &str = "BEARING_SWEEP_PG_BIN";
/// The superuser `initdb` creates (trust authentication on the loopback only).
const DB_USER: &str = "bearing";
/// Seconds `pg_ctl` waits for the server to accept connections.
const START_WAIT_S: u32 = 60;

static CLUSTERS: AtomicU32 = AtomicU32::new(0);

/// A running throwaway cluster.
pub struct PgCluster {
    bin: PathBuf,
    dir: PathBuf,
    port: u16,
    /// Run the server's commands as this user (`Some` when the tests run as root).
    run_as: Option<String>,
}

/// Whether a missing PostgreSQL must fail the test.
pub fn required() -> bool {
    std::env::var(REQUIRE_ENV).is_ok_and(|v| v == "1")
}

/// The folder holding `initdb`, `pg_ctl` and `postgres`: `$BEARING_SWEEP_PG_BIN`, the
/// newest `/usr/lib/postgresql/<version>/bin` (Debian), or the folder of `pg_ctl` on PATH.
pub fn find_bin() -> Option<PathBuf> {
    let has_all = |d: &Path| {
        ["initdb", "pg_ctl", "postgres"]
            .iter()
            .all(|b| d.join(b).is_file())
    };
    if let Ok(d) = std::env::var(BIN_ENV) {
        let d = PathBuf::from(d);
        return has_all(&d).then_some(d);
    }
    let mut debian: Vec<(u32, PathBuf)> = std::fs::read_dir("/usr/lib/postgresql")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let v: u32 = e.file_name().to_str()?.split('.').next()?.parse().ok()?;
            Some((v, e.path().join("bin")))
        })
        .filter(|(_, d)| has_all(d))
        .collect();
    debian.sort();
    if let Some((_, d)) = debian.pop() {
        return Some(d);
    }
    std::env::var_os("PATH").and_then(|p| std::env::split_paths(&p).find(|d| has_all(d)))
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("an ephemeral port on 127.0.0.1")
}

impl PgCluster {
    /// Starts a fresh cluster, or returns `None` after a notice when PostgreSQL is not
    /// installed (panics instead when [`required`]).
    pub fn start_or_skip(test: &str) -> Option<PgCluster> {
        let Some(bin) = find_bin() else {
            let msg = format!(
                "{test}: no PostgreSQL found (set {BIN_ENV}, or apt-get install postgresql)"
            );
            if required() {
                panic!("{msg}; {REQUIRE_ENV}=1 makes this a failure");
            }
            eprintln!("SKIPPED {msg}");
            return None;
        };
        Some(Self::start(bin))
    }

    fn start(bin: PathBuf) -> PgCluster {
        // SAFETY: geteuid has no preconditions.
        let root = unsafe { libc::geteuid() } == 0;
        let n = CLUSTERS.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!(
            "bearing-sweep-pg-{}-{n}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.subsec_nanos())
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("sock")).expect("cluster folder");
        let run_as = root.then(|| "postgres".to_string());
        if let Some(user) = &run_as {
            let st = Command::new("chown")
                .arg("-R")
                .arg(format!("{user}:"))
                .arg(&dir)
                .status()
                .expect("chown");
            assert!(st.success(), "chown {} to {user} failed", dir.display());
        }
        let mut c = PgCluster {
            bin,
            dir,
            port: 0,
            run_as,
        };
        let out = c.pg(
            "initdb",
            &[
                "-D",
                c.data().to_str().unwrap(),
                "-U",
                DB_USER,
                "-A",
                "trust",
                "-E",
                "UTF8",
                "--locale=C",
                "--no-sync",
            ],
        );
        assert!(
            out.status.success(),
            "initdb failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        // A port taken between free_port and the server's bind: try another.
        let mut last = String::new();
        for _ in 0..5 {
            c.port = free_port();
            match c.pg_ctl_start() {
                Ok(()) => return c,
                Err(e) => last = e,
            }
        }
        panic!("postgres did not start: {last}");
    }

    fn data(&self) -> PathBuf {
        self.dir.join("data")
    }

    /// Runs PostgreSQL program `prog` with `args` as the cluster's user.
    fn pg(&self, prog: &str, args: &[&str]) -> Output {
        let exe = self.bin.join(prog);
        let mut cmd = match &self.run_as {
            Some(user) => {
                let mut c = Command::new("runuser");
                c.args(["-u", user, "--"]).arg(&exe);
                c
            }
            None => Command::new(&exe),
        };
        cmd.args(args)
            .current_dir(&self.dir)
            .output()
            .unwrap_or_else(|e| panic!("{}: {e}", exe.display()))
    }

    fn pg_ctl_start(&self) -> Result<(), String> {
        // Durability settings off: a test cluster lives in a temporary folder, and a
        // restart (fast or immediate) still keeps everything (the OS keeps the pages).
        let opts = format!(
            "-h 127.0.0.1 -p {} -k {} -c fsync=off -c synchronous_commit=off -c full_page_writes=off -c max_connections=300",
            self.port,
            self.dir.join("sock").display()
        );
        let log = self.dir.join("postgres.log");
        let out = self.pg(
            "pg_ctl",
            &[
                "-D",
                self.data().to_str().unwrap(),
                "-l",
                log.to_str().unwrap(),
                "-w",
                "-t",
                &START_WAIT_S.to_string(),
                "-o",
                &opts,
                "start",
            ],
        );
        if out.status.success() {
            Ok(())
        } else {
            Err(format!(
                "{}{}\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr),
                std::fs::read_to_string(&log).unwrap_or_default()
            ))
        }
    }

    fn pg_ctl_stop(&self, mode: &str) -> bool {
        self.pg(
            "pg_ctl",
            &[
                "-D",
                self.data().to_str().unwrap(),
                "-m",
                mode,
                "-w",
                "stop",
            ],
        )
        .status
        .success()
    }

    /// Connection URL of the `postgres` database as the superuser.
    pub fn url(&self) -> String {
        format!("postgres://{DB_USER}@127.0.0.1:{}/postgres", self.port)
    }

    /// Creates database `name` and returns its URL (one cluster, several isolated stores).
    pub fn create_database(&self, name: &str) -> String {
        let out = self.pg(
            "createdb",
            &[
                "-h",
                "127.0.0.1",
                "-p",
                &self.port.to_string(),
                "-U",
                DB_USER,
                name,
            ],
        );
        assert!(
            out.status.success(),
            "createdb {name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        format!("postgres://{DB_USER}@127.0.0.1:{}/{name}", self.port)
    }

    /// Stops the server (fast shutdown: open connections are closed), stays down for
    /// `down`, and starts it again on the same port and data.
    pub fn restart(&self, down: Duration) {
        assert!(self.pg_ctl_stop("fast"), "pg_ctl stop failed");
        std::thread::sleep(down);
        self.pg_ctl_start()
            .expect("postgres restarts on the same port");
    }

    /// The server's log so far (for failure messages).
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("postgres.log")).unwrap_or_default()
    }
}

impl Drop for PgCluster {
    fn drop(&mut self) {
        let _ = self.pg_ctl_stop("immediate");
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// `worker` processes of the binary under test on one database, each logging to
/// `dir/w{k}.log`, on one rayon thread each; killed when dropped.
pub struct Workers(Vec<Child>);

impl Workers {
    /// Starts `n` workers claiming `batch` variants at a time with leases of
    /// `lease_ttl_s` seconds (heartbeat every 0.25 s).
    pub fn start(url: &str, n: usize, batch: usize, lease_ttl_s: u32, dir: &Path) -> Workers {
        Workers(
            (0..n)
                .map(|k| {
                    Command::new(env!("CARGO_BIN_EXE_bearing-sweep"))
                        .args([
                            "worker",
                            "--database",
                            url,
                            "--batch",
                            &batch.to_string(),
                            "--lease-ttl",
                            &lease_ttl_s.to_string(),
                            "--heartbeat",
                            "0.25",
                            "--id",
                            &format!("w{k}"),
                        ])
                        .env("RAYON_NUM_THREADS", "1")
                        .stdout(Stdio::null())
                        .stderr(std::fs::File::create(dir.join(format!("w{k}.log"))).unwrap())
                        .spawn()
                        .expect("worker starts")
                })
                .collect(),
        )
    }
}

impl Drop for Workers {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}
