//! Bad input never yields NaN or infinite loads: each bad state gets a status naming its
//! index and the reason, bad bearings an error naming the field; the `eval` CLI reports
//! them with the JSON path and exit status 2.

mod common;

use bearing_sweep::backend::{CpuBackend, LoadEvaluator, LoadRequest, LoadResult};
use bearing_sweep::bearing::reference::reference_loads;
use bearing_sweep::bearing::{
    film_loads, Accuracy, BearingParams, BearingState, End, FilmRule, Loads, StateFault,
};
use common::*;

fn evaluate(bearings: &[BearingParams], requests: &[LoadRequest]) -> Vec<LoadResult> {
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    let mut out = Vec::new();
    ev.evaluate(bearings, requests, &mut out);
    assert_eq!(out.len(), requests.len());
    out
}

fn req(state: BearingState) -> LoadRequest {
    LoadRequest { bearing: 0, state }
}

fn good_state() -> BearingState {
    BearingState {
        xi: 1e-4,
        yi: -2e-5,
        xj: 5e-5,
        yj: 1e-4,
        vxi: 1e-3,
        vyi: 0.0,
        vxj: -1e-3,
        vyj: 2e-3,
        omega: 100.0,
    }
}

fn assert_finite(index: usize, l: &Loads) {
    let mut v = vec![l.wx, l.wy, l.mx, l.my, l.mz, l.h_min, l.power_loss];
    v.extend(l.friction_coefficient);
    v.extend(l.sommerfeld);
    assert!(
        v.iter().all(|x| x.is_finite()),
        "[{index}] non-finite loads {l:?}"
    );
}

/// `ε >= 1` at either end: `through_wall`, naming the end and the ratio; the good states
/// of the same batch are unaffected.
#[test]
fn journal_through_the_wall() {
    let p = table2();
    let d = p.clearance;
    let cases = [
        (
            BearingState {
                xi: d,
                ..good_state()
            },
            End::I,
        ),
        (
            BearingState {
                yi: -1.5 * d,
                ..good_state()
            },
            End::I,
        ),
        (
            BearingState {
                xj: 0.6 * d,
                yj: 0.8 * d,
                ..good_state()
            },
            End::J,
        ),
        (
            BearingState {
                xj: -2.0 * d,
                ..good_state()
            },
            End::J,
        ),
    ];
    let mut requests = vec![req(good_state())];
    requests.extend(cases.iter().map(|c| req(c.0)));
    requests.push(req(good_state()));
    let out = evaluate(&[p], &requests);
    assert!(out[0].is_ok() && out[out.len() - 1].is_ok());
    for (k, (_, end)) in cases.iter().enumerate() {
        match &out[k + 1] {
            Err(f @ StateFault::ThroughWall { end: e, ratio }) => {
                assert_eq!(e, end, "[{k}]");
                assert!(*ratio >= 1.0, "[{k}] ratio {ratio}");
                assert_eq!(f.code(), "through_wall");
                let msg = f.to_string();
                assert!(msg.contains("wall") && msg.contains(">= 1"), "[{k}] {msg}");
            }
            other => panic!("[{k}] expected through_wall at {end:?}, got {other:?}"),
        }
    }
    // Just inside the wall is fine and finite.
    let inside = BearingState {
        xi: 0.999_999 * d,
        yi: 0.0,
        xj: 0.999_999 * d,
        yj: 0.0,
        ..good_state()
    };
    let out = evaluate(&[p], &[req(inside)]);
    assert_finite(0, out[0].as_ref().expect("inside the wall"));
}

/// NaN or infinity in each field: `non_finite_input` naming that field.
#[test]
fn non_finite_inputs_name_the_field() {
    let p = table2();
    let names = ["xi", "yi", "xj", "yj", "vxi", "vyi", "vxj", "vyj", "omega"];
    let mut index = 0;
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for (k, name) in names.iter().enumerate() {
            let mut s = good_state();
            let fields: [&mut f64; 9] = [
                &mut s.xi,
                &mut s.yi,
                &mut s.xj,
                &mut s.yj,
                &mut s.vxi,
                &mut s.vyi,
                &mut s.vxj,
                &mut s.vyj,
                &mut s.omega,
            ];
            *fields.into_iter().nth(k).unwrap() = bad;
            let out = evaluate(&[p], &[req(good_state()), req(s)]);
            assert!(out[0].is_ok());
            match &out[1] {
                Err(f @ StateFault::NonFinite { field }) => {
                    assert_eq!(field, name, "[{index}]");
                    assert_eq!(f.code(), "non_finite_input");
                    assert!(f.to_string().contains(name));
                }
                other => panic!("[{index}] {name} = {bad}: got {other:?}"),
            }
            // The single-state path agrees.
            let rule = FilmRule::new(Accuracy::default().settings());
            assert!(matches!(
                film_loads(&p, &s, &rule),
                Err(StateFault::NonFinite { .. })
            ));
            assert!(reference_loads(&p, &s, 1e-10).is_err());
            index += 1;
        }
    }
}

/// Unusable bearing parameters: every state of that bearing gets `invalid_bearing` naming
/// the field; states of other bearings are unaffected; an index past the list is named.
#[test]
fn invalid_bearings() {
    let good = table2();
    let cases: Vec<(BearingParams, &str)> = vec![
        (
            BearingParams {
                radius: 0.0,
                ..good
            },
            "radius",
        ),
        (
            BearingParams {
                length: -0.02,
                ..good
            },
            "length",
        ),
        (
            BearingParams {
                clearance: -3e-4,
                ..good
            },
            "clearance",
        ),
        (
            BearingParams {
                clearance: 0.02,
                ..good
            },
            "clearance",
        ),
        (
            BearingParams {
                viscosity: 0.0,
                ..good
            },
            "viscosity",
        ),
        (
            BearingParams {
                viscosity: f64::NAN,
                ..good
            },
            "viscosity",
        ),
        (
            BearingParams {
                radius: f64::INFINITY,
                ..good
            },
            "radius",
        ),
    ];
    for (k, (bad, field)) in cases.iter().enumerate() {
        assert_eq!(bad.validate().unwrap_err().field, *field, "[{k}]");
        let requests = [
            LoadRequest {
                bearing: 0,
                state: good_state(),
            },
            LoadRequest {
                bearing: 1,
                state: good_state(),
            },
            LoadRequest {
                bearing: 2,
                state: good_state(),
            },
        ];
        let out = evaluate(&[good, *bad], &requests);
        assert!(out[0].is_ok(), "[{k}]");
        match &out[1] {
            Err(f @ StateFault::InvalidBearing { field: got, .. }) => {
                assert_eq!(got, field, "[{k}]");
                assert_eq!(f.code(), "invalid_bearing");
            }
            other => panic!("[{k}] {field}: got {other:?}"),
        }
        match &out[2] {
            Err(StateFault::InvalidBearing {
                field: "bearing",
                reason,
            }) => {
                assert!(reason.contains("out of range"), "[{k}] {reason}")
            }
            other => panic!("[{k}] index 2 of 2 bearings: got {other:?}"),
        }
    }
}

/// The centred, motionless journal: zero loads, zero friction, `f` and `S` null.
/// A centred spinning journal: zero film force, finite `M_z`, `f` null.
#[test]
fn zero_states() {
    let p = table2();
    let still = BearingState::default();
    let spinning = BearingState {
        omega: 100.0,
        ..still
    };
    let out = evaluate(&[p], &[req(still), req(spinning)]);
    let l = out[0].as_ref().unwrap();
    assert_finite(0, l);
    assert_eq!([l.wx, l.wy, l.mx, l.my, l.mz, l.power_loss], [0.0; 6]);
    assert_eq!((l.friction_coefficient, l.sommerfeld), (None, None));
    assert_eq!(l.h_min, p.clearance);
    let l = out[1].as_ref().unwrap();
    assert_finite(1, l);
    assert_eq!([l.wx, l.wy, l.mx, l.my], [0.0; 4]);
    assert!(l.mz < 0.0);
    assert_eq!(l.friction_coefficient, None);
    // Serialises with JSON nulls, never infinity.
    let json = serde_json::to_value(l).unwrap();
    assert!(json["friction_coefficient"].is_null());
    assert!(json["mz"].as_f64().unwrap().is_finite());
}

/// Huge but finite inputs never produce NaN or infinite outputs: either finite loads or
/// the `overflow` fault naming the quantity.
#[test]
fn huge_finite_inputs_stay_finite_or_fail_cleanly() {
    let p = table2();
    let d = p.clearance;
    let mut cases = Vec::new();
    for big in [1e150, 1e200, 1e300, f64::MAX] {
        cases.push(BearingState {
            omega: big,
            ..good_state()
        });
        cases.push(BearingState {
            omega: -big,
            xi: 0.99 * d,
            yi: 0.0,
            xj: 0.99 * d,
            yj: 0.0,
            ..good_state()
        });
        cases.push(BearingState {
            vxi: big,
            ..good_state()
        });
        cases.push(BearingState {
            vyj: -big,
            vxj: big,
            ..good_state()
        });
        cases.push(BearingState {
            vxi: big,
            vxj: big,
            omega: big,
            ..good_state()
        });
    }
    // Tiny and huge geometry.
    let tiny = BearingParams {
        radius: 1e-300,
        length: 1e-300,
        clearance: 1e-301,
        viscosity: 1e-300,
        ..p
    };
    let huge = BearingParams {
        radius: 1e300,
        length: 1e300,
        clearance: 1e299,
        viscosity: 1e300,
        ..p
    };
    let requests: Vec<LoadRequest> = cases.iter().map(|&s| req(s)).collect();
    for (bname, b) in [("table2", p), ("tiny", tiny), ("huge", huge)] {
        let scaled: Vec<LoadRequest> = requests
            .iter()
            .map(|r| {
                let k = b.clearance / p.clearance;
                let s = r.state;
                req(BearingState {
                    xi: s.xi * k,
                    yi: s.yi * k,
                    xj: s.xj * k,
                    yj: s.yj * k,
                    ..s
                })
            })
            .collect();
        let out = evaluate(&[b], &scaled);
        for (k, r) in out.iter().enumerate() {
            match r {
                Ok(l) => assert_finite(k, l),
                Err(f) => {
                    let msg = f.to_string();
                    assert!(
                        matches!(f, StateFault::Overflow { .. }) && f.code() == "overflow",
                        "[{k}] {bname}: unexpected fault {f:?}"
                    );
                    println!("[{k}] {bname}: {} ({msg})", f.code());
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// The `eval` command line.

fn run_eval(args: &[&str], stdin: Option<&str>) -> (i32, serde_json::Value, String) {
    use std::io::Write;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_bearing-sweep"))
        .arg("eval")
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run bearing-sweep");
    {
        let mut input = child.stdin.take().unwrap();
        if let Some(text) = stdin {
            input.write_all(text.as_bytes()).unwrap();
        }
    }
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    let json = serde_json::from_str(&stdout).unwrap_or(serde_json::Value::Null);
    (
        out.status.code().unwrap_or(-1),
        json,
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

const BEARING: &str =
    r#""bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}"#;

/// The example file: four states, the fourth through the wall at end `i`, named by index.
#[test]
fn cli_eval_example_file() {
    let (code, out, stderr) = run_eval(&["sweeps/eval-states.json"], None);
    assert_eq!(code, 0, "stderr: {stderr}");
    let loads = out["loads"].as_array().expect("loads array");
    assert_eq!(loads.len(), 4);
    // State 0 is aligned at ε = 0.5: Ocvirk.
    let p = table2();
    let (_, ocv) = ocvirk_model(&p, 0.5, 100.0);
    let got: Vec<f64> = ["wx", "wy", "mx", "my"]
        .iter()
        .map(|k| loads[0][k].as_f64().unwrap())
        .collect();
    assert_close("eval example state 0 vs Ocvirk", 0, &got, &ocv, 1e-12, 0.0);
    assert_eq!(loads[1]["status"], "ok");
    // State 2: centred, spinning: zero force, finite M_z, null f.
    assert_eq!(loads[2]["status"], "ok");
    assert_eq!(loads[2]["wx"].as_f64(), Some(0.0));
    assert!(loads[2]["friction_coefficient"].is_null());
    assert!(loads[2]["mz"].as_f64().unwrap() < 0.0);
    // State 3: through the wall, with its index in the message and null numbers.
    assert_eq!(loads[3]["status"], "through_wall");
    let msg = loads[3]["error"].as_str().unwrap();
    assert!(
        msg.starts_with("states[3]") && msg.contains("wall"),
        "{msg}"
    );
    assert!(loads[3]["wx"].is_null() && loads[3]["mz"].is_null());
    assert_eq!(out["clearance_convention"], "paper");
    assert_eq!(out["accuracy"].as_f64(), Some(1e-6));
}

/// `-` reads standard input; `--accuracy` picks a level; a non-finite-free bad state in
/// the middle of a batch is reported by index and does not disturb its neighbours.
#[test]
fn cli_eval_stdin_and_bad_state_by_index() {
    let doc = format!(
        r#"{{{BEARING}, "states": [
        {{"xi": 1e-4, "yi": 0, "xj": 1e-4, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100}},
        {{"xi": 0, "yi": 0, "xj": 0, "yj": -0.0004, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100}},
        {{"xi": 1e-4, "yi": 0, "xj": 1e-4, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 1e200}}
    ]}}"#
    );
    let (code, out, stderr) = run_eval(&["-", "--accuracy", "1e-9"], Some(&doc));
    assert_eq!(code, 0, "stderr: {stderr}");
    assert_eq!(out["accuracy"].as_f64(), Some(1e-9));
    let loads = out["loads"].as_array().unwrap();
    assert_eq!(loads[0]["status"], "ok");
    assert_eq!(loads[1]["status"], "through_wall");
    let msg = loads[1]["error"].as_str().unwrap();
    assert!(
        msg.starts_with("states[1]") && msg.contains("end j (z = B)"),
        "{msg}"
    );
    assert_eq!(loads[2]["status"], "overflow");
    assert!(loads[2]["error"].as_str().unwrap().starts_with("states[2]"));
}

/// Input errors stop the command with exit status 2 and a message naming the JSON path.
#[test]
fn cli_eval_input_errors() {
    let state = r#"{"xi": 1e-4, "yi": 0, "xj": 1e-4, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100}"#;
    let cases = [
        (
            format!(
                r#"{{"bearing": {{"radius": 0.02, "length": 0.02, "clearance": -0.0003, "viscosity": 0.0242}}, "states": [{state}]}}"#
            ),
            "bearing.clearance",
        ),
        (
            format!(
                r#"{{"bearing": {{"radius": 0.02, "length": 0.02, "clearance": 0.03, "viscosity": 0.0242}}, "states": [{state}]}}"#
            ),
            "bearing.clearance",
        ),
        (
            format!(r#"{{{BEARING}, "states": [{state}], "extra": 1}}"#),
            "extra: unknown field",
        ),
        (
            format!(r#"{{{BEARING}, "states": [{state}, {{"xi": 0, "wobble": 1}}]}}"#),
            "states[1]",
        ),
        (
            r#"{"bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "colour": 1}, "states": []}"#
                .to_string(),
            "bearing.colour: unknown field `colour`",
        ),
        (
            format!(r#"{{{BEARING}, "states": [{state}"#),
            "not valid JSON",
        ),
        (format!(r#"{{{BEARING}}}"#), "states: missing"),
        ("[1, 2]".to_string(), "expected an object"),
    ];
    for (k, (doc, needle)) in cases.iter().enumerate() {
        let (code, out, stderr) = run_eval(&["-"], Some(doc));
        assert_eq!(code, 2, "[{k}] exit status; stderr {stderr}");
        assert!(out.is_null(), "[{k}] no output document expected: {out}");
        assert!(
            stderr.contains("error:") && stderr.contains(needle),
            "[{k}] stderr {stderr:?} should name {needle:?}"
        );
    }
    // A missing file is an error naming the path.
    let (code, _, stderr) = run_eval(&["no/such/file.json"], None);
    assert_eq!(code, 2);
    assert!(stderr.contains("no/such/file.json"), "{stderr}");
}
