use crate::testkit::{cobalt, temp_dir};

/// A tiny matrix end to end, every cell run twice: every promised JSON field, fractions in
/// range, each cell's runs listed, the simulator's records, and the charts.
#[test]
fn bench_writes_one_record_per_run_and_the_charts() {
    let dir = temp_dir("bench");
    let (json, plots) = (dir.join("b.json"), dir.join("plots"));
    let (json_s, plots_s) = (json.display().to_string(), plots.display().to_string());
    let o = cobalt(&[
        "bench",
        "--scene",
        "builtin:cornell:0.2",
        "--size",
        "32x32",
        "--task-sizes",
        "256",
        "--policies",
        "static-lpt,queue-fifo",
        "--ao-samples",
        "4",
        "--repeats",
        "2",
        "--simulate",
        "2,8",
        "--json",
        &json_s,
        "--plots",
        &plots_s,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("| static-lpt | cost |"), "{text}");
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("valid JSON");
    let runs = v.as_array().expect("an array of runs");
    let measured: Vec<_> = runs.iter().filter(|r| r["source"] == "measured").collect();
    // 2 shaders × 1 task size × 2 policies × 2 modes.
    assert_eq!(measured.len(), 8);
    for r in &measured {
        for field in [
            "scene",
            "shader",
            "ray_kind",
            "policy",
            "mode",
            "task_size",
            "devices",
            "rays",
            "seconds",
            "mrays_per_s",
            "balance_efficiency",
            "estimate_seconds",
            "plan_seconds",
            "prediction_error",
        ] {
            assert!(r.get(field).is_some(), "{field} missing in {r}");
        }
        // CPU devices render their paths where they live: nothing crosses a link.
        assert_eq!(r["host_to_device_bytes"], 0, "{r}");
        assert_eq!(r["device_to_host_bytes"], 0, "{r}");
        let balance = r["balance_efficiency"].as_f64().expect("balance");
        assert!(balance > 0.0 && balance <= 1.0 + 1e-9, "{r}");
        assert!(r["rays"].as_u64().is_some_and(|n| n > 0), "{r}");
        // Two runs of the cell, the median of two being their mean.
        assert_eq!(r["repeats"], 2, "{r}");
        let runs: Vec<f64> = r["run_balance_efficiency"]
            .as_array()
            .expect("every run's balance")
            .iter()
            .filter_map(|b| b.as_f64())
            .collect();
        assert_eq!(runs.len(), 2, "{r}");
        assert!((balance - 0.5 * (runs[0] + runs[1])).abs() < 1e-12, "{r}");
        assert_eq!(r["run_mrays_per_s"].as_array().map(Vec::len), Some(2));
        if r["mode"] == "cost" {
            let e = r["prediction_error"]
                .as_f64()
                .expect("cost runs have an error");
            assert!((0.0..1.0).contains(&e), "{r}");
        } else {
            assert!(r["prediction_error"].is_null(), "{r}");
        }
    }
    let simulated = runs.iter().filter(|r| r["source"] == "simulated").count();
    // 2 shaders × 1 size × 2 device counts × 2 links × 5 policies × 2 modes.
    assert_eq!(simulated, 80);
    // Table 4.1's trade: 2 ray kinds × 1 task size × 6 rates of the bench's walk, beside the
    // thesis where it has the rate, and full sampling exact; the trace walk's 4 rates, and its
    // sample refined as `cobalt estimate` takes it.
    let trade: Vec<_> = runs
        .iter()
        .filter(|r| r["source"] == "sampling_trade")
        .collect();
    assert_eq!(trade.len(), 22);
    let traced = trade
        .iter()
        .filter(|p| p["walk"].as_str().is_some_and(|n| n.starts_with("trace")))
        .count();
    assert_eq!(traced, 10);
    for p in &trade {
        let rate = p["sample_rate"].as_f64().expect("rate");
        let error = p["prediction_error"].as_f64().expect("error");
        assert!(p["overhead"].as_f64().is_some_and(|o| o > 0.0), "{p}");
        assert!(p["meets_target"].is_boolean(), "{p}");
        // What the estimates buy an 8-device LPT plan: a balance in (0, 1].
        let balance = p["lpt_balance"].as_f64();
        assert!(balance.is_some_and(|b| b > 0.0 && b <= 1.0 + 1e-12), "{p}");
        // The thesis's figures stand beside its own walk's rows.
        let reduced_walk = p["walk"] == "reduced";
        assert_eq!(
            p["thesis_overhead"].is_null(),
            rate < 0.125 || !reduced_walk,
            "{p}"
        );
        if rate == 1.0 {
            assert_eq!(error, 0.0, "{p}");
        }
    }
    for chart in ["mrays.png", "balance.png", "sampling.png", "cost.png"] {
        let bytes = std::fs::read(plots.join(chart)).expect("chart written");
        assert_eq!(&bytes[..4], b"\x89PNG", "{chart}");
    }
}

#[test]
fn bench_rejects_bad_values_naming_them() {
    // The value the error names: in a list, the bad item.
    for (flag, value, named) in [
        ("--task-sizes", "0", "0"),
        ("--task-sizes", "512,0", "0"),
        ("--policies", "lpt,nope", "nope"),
        ("--shaders", "phong", "phong"),
        ("--sample-rate", "2", "2"),
        ("--devices", "cpu:0", "cpu:0"),
        ("--simulate", "x", "x"),
        ("--simulate", "8,0", "0"),
        ("--repeats", "0", "0"),
        ("--cameras", "5", "5"),
        ("--scene", "/no/such/scene.obj", "/no/such/scene.obj"),
    ] {
        let o = cobalt(&["bench", flag, value]);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}");
        let err = String::from_utf8_lossy(&o.stderr);
        // A file's error names the file; a flag's names the flag and quotes the value.
        let ok = if flag == "--scene" {
            err.contains(named)
        } else {
            err.contains(flag)
                && (err.contains(&format!("'{named}'")) || err.contains(&format!("{named:?}")))
        };
        assert!(ok, "{flag} {value}: {err}");
    }
}
