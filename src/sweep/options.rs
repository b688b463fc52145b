//! The options a sweep runs with, one type whoever runs it (`run`, the service's query,
//! the PostgreSQL queue): the film backend, the requested film accuracy and whether every
//! model reduction is off. The service and the queue store it as the JSON object
//! `{"backend", "accuracy", "full_model"}`.

use serde::{Deserialize, Deserializer, Serialize};

use crate::backend::BackendKind;
use crate::bearing::Accuracy;
use crate::budget::MemoryBudget;

/// A requested film accuracy (relative): a positive number not tighter than 1e-12. It is
/// kept as given (stored and echoed so); [`RequestedAccuracy::level`] is the calibrated
/// level the film is computed at.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct RequestedAccuracy(f64);

impl RequestedAccuracy {
    /// `rtol` if it is a valid request, else the reason (one wording for every command
    /// and route: "X is not a positive number >= 1e-12").
    pub fn new(rtol: f64) -> Result<Self, String> {
        match Accuracy::new(rtol) {
            Some(_) => Ok(RequestedAccuracy(rtol)),
            None => Err(refusal(rtol)),
        }
    }

    /// The requested relative accuracy, as given.
    pub fn rtol(self) -> f64 {
        self.0
    }

    /// The calibrated level the film is computed at (the loosest at least as tight).
    pub fn level(self) -> Accuracy {
        Accuracy::new(self.0).unwrap_or_default()
    }
}

impl Default for RequestedAccuracy {
    /// 1e-6, the default level.
    fn default() -> Self {
        RequestedAccuracy(Accuracy::default().rtol())
    }
}

impl<'de> Deserialize<'de> for RequestedAccuracy {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = f64::deserialize(d)?;
        RequestedAccuracy::new(v).map_err(serde::de::Error::custom)
    }
}

/// Why accuracy `shown` (a number, or the text given) is refused.
pub fn refusal(shown: impl std::fmt::Display) -> String {
    format!("{shown} is not a positive number >= 1e-12")
}

/// `rtol` as a calibrated accuracy level, or the reason it is refused.
pub fn accuracy_level(rtol: f64) -> Result<Accuracy, String> {
    RequestedAccuracy::new(rtol).map(RequestedAccuracy::level)
}

/// How a sweep runs: the choices of `run`'s flags, the service's query and the queue's
/// stored options, which shape the simulator (see `super::simulator::prepare_simulator`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SweepOptions {
    /// Film-load backend (`--backend`, `?backend`); default `auto`. For the PostgreSQL
    /// queue: which workers may run it (`auto`: any).
    pub backend: BackendKind,
    /// Requested film accuracy, relative (`--accuracy`, `?accuracy`); default 1e-6.
    pub accuracy: RequestedAccuracy,
    /// Every model reduction off (`--full-model`, `?full_model`); default false.
    pub full_model: bool,
    /// The memory budget the spec is checked against and rotor samples are capped by
    /// (`run --max-memory`, the service's `ServiceConfig::max_memory`); default 2 GiB.
    /// Not stored with a queued sweep: whoever runs it passes its own.
    #[serde(skip)]
    pub max_memory: MemoryBudget,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            backend: BackendKind::Auto,
            accuracy: RequestedAccuracy::default(),
            full_model: false,
            max_memory: MemoryBudget::default(),
        }
    }
}

impl SweepOptions {
    /// The backend's name as stored and matched by the queue: `cpu`, `gpu` or `auto`.
    pub fn backend_name(&self) -> &'static str {
        backend_name(self.backend)
    }
}

/// `cpu`, `gpu` or `auto`.
pub fn backend_name(kind: BackendKind) -> &'static str {
    match kind {
        BackendKind::Cpu => "cpu",
        BackendKind::Gpu => "gpu",
        BackendKind::Auto => "auto",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_round_trip_as_the_stored_json() {
        let o = SweepOptions {
            backend: BackendKind::Cpu,
            accuracy: RequestedAccuracy::new(1e-5).unwrap(),
            full_model: true,
            max_memory: MemoryBudget::default(),
        };
        let v = serde_json::to_value(o).unwrap();
        assert_eq!(
            v,
            serde_json::json!({"backend": "cpu", "accuracy": 1e-5, "full_model": true})
        );
        assert_eq!(serde_json::from_value::<SweepOptions>(v).unwrap(), o);
        // Missing fields take the defaults.
        let d: SweepOptions = serde_json::from_value(serde_json::json!({})).unwrap();
        assert_eq!(d, SweepOptions::default());
        assert_eq!(d.accuracy.rtol(), 1e-6);
        // The requested value is kept; the level is the calibrated one.
        assert_eq!(o.accuracy.rtol(), 1e-5);
        assert_eq!(o.accuracy.level().rtol(), 1e-6);
    }

    #[test]
    fn a_bad_accuracy_is_refused_with_one_wording() {
        for bad in [0.0, -1.0, 1e-13, f64::NAN, f64::INFINITY] {
            let e = RequestedAccuracy::new(bad).unwrap_err();
            assert_eq!(e, format!("{bad} is not a positive number >= 1e-12"));
        }
        let e = serde_json::from_value::<SweepOptions>(serde_json::json!({"accuracy": 0.0}))
            .unwrap_err()
            .to_string();
        assert!(e.contains("0 is not a positive number >= 1e-12"), "{e}");
        for good in [1e-12, 1e-3, 0.5] {
            assert_eq!(RequestedAccuracy::new(good).unwrap().rtol(), good);
        }
    }
}
