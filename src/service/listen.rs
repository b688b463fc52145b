//! The listening side of `serve`: one server per store folder (an advisory lock on
//! `DIR/serve.lock` naming the holder's pid), and the accept loop: a header timeout on
//! every connection (a client that sends half a header is closed after it), at most so
//! many connections open per client address, graceful shutdown on a signal.

use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Seek, Write};
use std::net::IpAddr;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::Router;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;

use super::ServeError;

/// How long a graceful shutdown waits for open connections to finish their requests.
const DRAIN_CONNECTIONS: Duration = Duration::from_secs(10);
/// Pause after a failed accept (out of file descriptors): the error is transient.
const ACCEPT_BACKOFF: Duration = Duration::from_millis(50);

/// The lock of a store folder, held while the server runs (released by the operating
/// system if the process dies, whatever the signal).
pub struct DataLock {
    _file: File,
}

impl DataLock {
    /// Takes `dir/serve.lock` (creating the folder), or says which process holds it.
    pub fn acquire(dir: &Path) -> Result<DataLock, ServeError> {
        std::fs::create_dir_all(dir).map_err(|source| ServeError::Io {
            what: format!("creating the store folder {}", dir.display()),
            source,
        })?;
        let path = dir.join("serve.lock");
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|source| ServeError::Io {
                what: format!("opening the lock file {}", path.display()),
                source,
            })?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                let holder = holder.trim();
                let who = if holder.is_empty() {
                    "another process".to_string()
                } else {
                    format!("process {holder}")
                };
                return Err(ServeError::Busy(format!(
                    "the store folder {} is in use by another `serve` ({who} holds {}): two servers on one store would run the same sweeps twice. Stop it, or give this one another --data",
                    dir.display(),
                    path.display()
                )));
            }
            Err(std::fs::TryLockError::Error(source)) => {
                return Err(ServeError::Io {
                    what: format!("locking {}", path.display()),
                    source,
                })
            }
        }
        // The holder's pid, for the message of the next one.
        let _ = file.set_len(0);
        let _ = file.rewind();
        let _ = writeln!(file, "{}", std::process::id());
        let _ = file.flush();
        Ok(DataLock { _file: file })
    }
}

/// Limits of the accept loop.
#[derive(Clone, Copy, Debug)]
pub struct ConnLimits {
    /// Time to send a request's header, from its first byte.
    pub header_timeout: Duration,
    /// Most connections open at once from one address.
    pub per_client: usize,
}

/// Open connections per client address.
#[derive(Default)]
struct Counts(Mutex<HashMap<IpAddr, usize>>);

/// One counted connection; uncounted on drop.
struct Slot {
    counts: Arc<Counts>,
    ip: IpAddr,
}

impl Counts {
    fn take(self: &Arc<Self>, ip: IpAddr, max: usize) -> Option<Slot> {
        let mut m = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let n = m.entry(ip).or_insert(0);
        if *n >= max {
            return None;
        }
        *n += 1;
        Some(Slot {
            counts: self.clone(),
            ip,
        })
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        let mut m = self.counts.0.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = m.get_mut(&self.ip) {
            *n -= 1;
            if *n == 0 {
                m.remove(&self.ip);
            }
        }
    }
}

/// Serves `app` on `listener` until `signal` completes, then stops accepting, lets open
/// connections finish their requests (up to [`DRAIN_CONNECTIONS`]) and returns.
pub async fn serve(
    listener: tokio::net::TcpListener,
    app: Router,
    limits: ConnLimits,
    signal: impl std::future::Future<Output = ()> + Send + 'static,
) {
    let counts = Arc::new(Counts::default());
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let mut tasks = tokio::task::JoinSet::new();
    let mut signal = std::pin::pin!(signal);
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(a) => a,
                Err(e) => {
                    tracing::warn!("accept: {e}");
                    tokio::time::sleep(ACCEPT_BACKOFF).await;
                    continue;
                }
            },
            _ = &mut signal => break,
        };
        // Reap finished connection tasks as we go.
        while tasks.try_join_next().is_some() {}
        let Some(slot) = counts.take(peer.ip(), limits.per_client) else {
            // Over the limit: closed at once (the client sees a reset or EOF).
            tracing::debug!("refusing a connection from {peer}: too many open");
            drop(stream);
            continue;
        };
        let _ = stream.set_nodelay(true);
        let service = TowerToHyperService::new(app.clone());
        let mut stop = stop_rx.clone();
        tasks.spawn(async move {
            let _slot = slot;
            let mut builder = http1::Builder::new();
            builder
                .timer(TokioTimer::new())
                .header_read_timeout(limits.header_timeout);
            let conn = builder
                .serve_connection(TokioIo::new(stream), service)
                .with_upgrades();
            let mut conn = std::pin::pin!(conn);
            loop {
                tokio::select! {
                    r = conn.as_mut() => {
                        if let Err(e) = r {
                            tracing::debug!("connection from {peer}: {e}");
                        }
                        break;
                    }
                    _ = stop.changed() => {
                        conn.as_mut().graceful_shutdown();
                    }
                }
            }
        });
    }
    drop(listener);
    let _ = stop_tx.send(true);
    let _ = tokio::time::timeout(DRAIN_CONNECTIONS, async {
        while tasks.join_next().await.is_some() {}
    })
    .await;
}
