use crate::testkit::{cobalt, temp_dir};

/// `cobalt bench` on a tiny matrix (a small scene and image, two policies, few AO rays) with
/// `more` arguments.
fn tiny_bench(more: &[&str]) -> std::process::Output {
    let tiny = ["bench", "--scene", "builtin:cornell:0.2", "--size", "32x32"];
    let policies = ["--policies", "static-lpt,queue-fifo", "--ao-samples", "4"];
    cobalt(&[&tiny[..], &policies, more].concat())
}

/// A tiny matrix end to end, every cell run twice: every promised JSON field, fractions in
/// range, each cell's runs listed, the simulator's records, and the charts.
#[test]
fn bench_writes_one_record_per_run_and_the_charts() {
    let dir = temp_dir("bench");
    let (json, plots) = (dir.join("b.json"), dir.join("plots"));
    let (json_s, plots_s) = (json.display().to_string(), plots.display().to_string());
    let o = tiny_bench(&[
        "--task-sizes",
        "256",
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
    // Per shader, the first cost-mode frame is estimated and the other three (the next
    // policy, and both policies' second runs: the same camera and tasks) take its work; the
    // untimed warm-up frame before the cells is Whitted's first, cut as these are.
    for (shader, reused_cost) in [("whitted", 4), ("ao", 3)] {
        let reused = |mode: &str| -> u64 {
            (measured.iter())
                .filter(|r| r["shader"] == shader && r["mode"] == mode)
                .map(|r| r["estimates_reused"].as_u64().expect("a count"))
                .sum()
        };
        assert_eq!(
            (reused("cost"), reused("regular")),
            (reused_cost, 0),
            "{shader}"
        );
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
        ("--project", "tpu:4", "tpu:4"),
        ("--project", "gpu:all", "gpu:all"),
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

/// `--project cpu:2,cpu:4`: the measured tasks on machines of identical devices, one record
/// per workload, task size, policy and mode of each, deterministic and scaling with devices.
#[test]
fn bench_projects_the_measured_tasks_on_more_devices_of_a_class() {
    let dir = temp_dir("bench-project");
    let json = dir.join("p.json");
    let json_s = json.display().to_string();
    let o = tiny_bench(&[
        "--task-sizes",
        "64,32",
        "--no-trade",
        "--project",
        "cpu:2,cpu:4",
        "--json",
        &json_s,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("| cpu:2 | cpu:4 |"), "{text}");
    assert!(
        text.contains("Assumptions: every projected device is identical"),
        "{text}"
    );
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("valid JSON");
    let runs = v.as_array().expect("an array of runs");
    let projected: Vec<_> = runs.iter().filter(|r| r["source"] == "projected").collect();
    // 2 shaders × 2 task sizes × 2 policies × 2 modes × 2 machines.
    assert_eq!(projected.len(), 32);
    let mrays = |shader: &str, size: u64, policy: &str, mode: &str, list: &str| {
        let r = projected.iter().find(|r| {
            (r["shader"] == shader && r["task_size"] == size && r["policy"] == policy)
                && (r["mode"] == mode && r["device_list"] == list)
        });
        r.and_then(|r| r["mrays_per_s"].as_f64())
            .expect("a record of every cell and machine")
    };
    for r in &projected {
        let n = r["devices"].as_u64().expect("devices");
        assert_eq!(r["device_list"], format!("cpu:{n}"), "{r}");
        let m = r["mrays_per_s"].as_f64().expect("MRays/s");
        assert!(m.is_finite() && m > 0.0, "{r}");
        let balance = r["balance_efficiency"].as_f64().expect("balance");
        assert!(balance > 0.0 && balance <= 1.0 + 1e-9, "{r}");
    }
    for shader in ["whitted", "ao"] {
        for size in [64, 32] {
            for mode in ["regular", "cost"] {
                let (two, four) = (
                    mrays(shader, size, "static-lpt", mode, "cpu:2"),
                    mrays(shader, size, "static-lpt", mode, "cpu:4"),
                );
                assert!(four >= 0.95 * two, "{shader} {size} {mode}: {four} < {two}");
            }
        }
    }
}

/// A class the run did not measure cannot be projected: refused before anything runs.
#[test]
fn bench_refuses_to_project_an_unmeasured_class() {
    let o = cobalt(&["bench", "--devices", "cpu:1", "--project", "cpu:2,gpu:4"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("gpu") && err.contains("no measured device of this class"),
        "{err}"
    );
    let o = cobalt(&["bench", "--project", "cpu:2,cpu:2"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("cpu:2 is listed twice"), "{err}");
    let o = cobalt(&["bench", "--project"]);
    assert_eq!(o.status.code(), Some(2));
}
