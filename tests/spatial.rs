use crate::testkit::cobalt;

/// Runs a small `cobalt <cmd> --json` and checks the record shape shared with `cobalt bench`.
fn json_report(args: &[&str]) -> serde_json::Value {
    let out = cobalt(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

fn check_shape(report: &serde_json::Value, policies: usize, deterministic: bool) {
    let records = report["records"].as_array().expect("records");
    // Regular and cost mode, real and simulated.
    assert_eq!(records.len(), policies * 4);
    for r in records {
        for field in [
            "workload",
            "policy",
            "mode",
            "task_size",
            "devices",
            "queries",
            "seconds",
            "queries_per_s",
            "balance_efficiency",
            "estimate_seconds",
            "plan_seconds",
            "prediction_error",
            "overhead",
        ] {
            assert!(r.get(field).is_some(), "{field} missing in {r}");
        }
        let mode = r["mode"].as_str().expect("mode");
        assert!(mode == "regular" || mode == "cost");
        assert_eq!(r["prediction_error"].is_null(), mode == "regular", "{r}");
        let b = r["balance_efficiency"].as_f64().expect("balance");
        assert!(b > 0.0 && b <= 1.0 + 1e-9, "{r}");
    }
    let trade = report["trade"].as_array().expect("trade");
    let last = trade.last().expect("rates");
    assert_eq!(last["sample_rate"], 1.0);
    // A timing estimator's "full" reference is another timing: only a counting one is exact.
    if deterministic {
        assert_eq!(
            last["prediction_error"], 0.0,
            "full sampling is the reference"
        );
    }
}

#[test]
fn knn_json_has_the_bench_record_shape() {
    let r = json_report(&[
        "knn",
        "--points",
        "20000",
        "--queries",
        "4000",
        "--task-size",
        "128",
        "--json",
    ]);
    check_shape(&r, 5, true);
    let r = json_report(&[
        "knn",
        "--points",
        "5000",
        "--queries",
        "1000",
        "--policy",
        "lpt",
        "--estimator",
        "sampled",
        "--json",
    ]);
    check_shape(&r, 1, false);
}

#[test]
fn collide_json_has_the_bench_record_shape() {
    let r = json_report(&[
        "collide",
        "--bodies",
        "2000",
        "--terrain",
        "16",
        "--task-size",
        "32",
        "--json",
    ]);
    check_shape(&r, 5, true);
}

#[test]
fn bad_arguments_exit_2_naming_flag_and_value() {
    for (args, flag, value) in [
        (&["knn", "--k", "0"][..], "--k", "0"),
        (&["knn", "--points", "10", "--k", "11"][..], "--k", "11"),
        (&["knn", "--sample-rate", "1.5"][..], "--sample-rate", "1.5"),
        (&["knn", "--estimator", "magic"][..], "--estimator", "magic"),
        (&["knn", "--task-size", "0"][..], "--task-size", "0"),
        (&["collide", "--devices", "0"][..], "--devices", "0"),
        (&["collide", "--sample-rate", "0"][..], "--sample-rate", "0"),
        (
            &["collide", "--policy", "fastest"][..],
            "--policy",
            "fastest",
        ),
    ] {
        let out = cobalt(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(flag) && err.contains(value), "{args:?}: {err}");
    }
}
