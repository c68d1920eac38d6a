use std::path::PathBuf;
use std::process::Output;

use sched::exact::optimal_makespan;
use sched::{Costs, Speeds};

use crate::testkit::{Rng, cobalt};

/// A file in a per-test temporary directory, removed with the process's temp dir.
fn write_temp(name: &str, text: &str) -> PathBuf {
    let path = crate::testkit::temp_dir("cli").join(name);
    std::fs::write(&path, text).expect("temp file");
    path
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn schedule_json_meets_the_bounds_against_an_exact_solver() {
    let mut rng = Rng::from_env(5);
    for case in 0..25 {
        let n = 1 + rng.below(10);
        let m = 1 + rng.below(4);
        let costs: Vec<f64> = (0..n).map(|_| (1 + rng.below(30)) as f64).collect();
        let text: String = costs.iter().map(|c| format!("{c}\n")).collect();
        let file = write_temp(&format!("costs{case}.txt"), &text);
        let speeds = vec!["1"; m].join(",");
        let opt = optimal_makespan(
            &Costs::new(costs.clone()).unwrap(),
            &Speeds::identical(m).unwrap(),
        );
        for (policy, factor) in [
            ("lpt", 4.0 / 3.0 - 1.0 / (3.0 * m as f64)),
            ("queue-fifo", 2.0 - 1.0 / m as f64),
        ] {
            let v = json(&cobalt(&[
                "schedule",
                "--costs",
                file.to_str().unwrap(),
                "--speeds",
                &speeds,
                "--policy",
                policy,
                "--json",
            ]));
            let makespan = v["makespan"].as_f64().unwrap();
            assert!(
                makespan <= factor * opt + 1e-9,
                "{policy}: {makespan} vs OPT {opt}: {costs:?} on {m}"
            );
            assert!(v["lower_bound"].as_f64().unwrap() <= opt + 1e-9);
            // The assignment must reproduce the reported makespan.
            let assignment: Vec<usize> = v["assignment"]
                .as_array()
                .unwrap()
                .iter()
                .map(|d| d.as_u64().unwrap() as usize)
                .collect();
            let mut loads = vec![0.0; m];
            for (t, &d) in assignment.iter().enumerate() {
                loads[d] += costs[t];
            }
            assert_eq!(
                loads.iter().cloned().fold(0.0, f64::max),
                makespan,
                "{policy}"
            );
        }
    }
}

#[test]
fn schedule_reruns_failed_work_exactly_once() {
    let file = write_temp("fail.txt", &"1\n".repeat(20));
    let path = file.to_str().unwrap();
    for policy in [
        "static-equal",
        "static-lpt",
        "queue-fifo",
        "queue-sorted",
        "hybrid",
    ] {
        let v = json(&cobalt(&[
            "schedule",
            "--costs",
            path,
            "--speeds",
            "1,1,2",
            "--policy",
            policy,
            "--fail",
            "2@1.25,0@3",
            "--json",
        ]));
        let assignment = v["assignment"].as_array().unwrap();
        assert_eq!(assignment.len(), 20);
        // Only device 1 survives to the end; everything after the faults is its.
        assert!(
            assignment.iter().all(|d| d.as_u64().unwrap() <= 2),
            "{policy}"
        );
        assert!(
            v["reruns"].as_u64().unwrap() >= 1,
            "{policy}: the fault at 1.25 cut a task"
        );
        assert!(v["guarantee"].is_null());
    }
    let out = cobalt(&[
        "schedule", "--costs", path, "--speeds", "1,1", "--fail", "0@1,1@2",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("all 2 devices failed"), "{err}");
}

#[test]
fn bad_input_names_file_line_and_value_and_prints_nothing() {
    let cases = [
        (
            "bad1.txt",
            "1\n2\nabc\n",
            "bad1.txt:3: \"abc\" is not a number",
        ),
        (
            "bad2.txt",
            "1\n-0.5\n",
            "bad2.txt:2: cost -0.5 must be finite",
        ),
        (
            "bad3.txt",
            "# header\n\ninf\n",
            "bad3.txt:3: cost inf must be finite",
        ),
        ("bad4.txt", "NaN\n", "bad4.txt:1: cost NaN must be finite"),
    ];
    for (name, text, expected) in cases {
        let file = write_temp(name, text);
        let out = cobalt(&["schedule", "--costs", file.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2));
        assert!(out.stdout.is_empty());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expected), "{err} lacks {expected}");
    }
    let good = write_temp("good.txt", "1\n2\n");
    let good = good.to_str().unwrap();
    for (args, expected) in [
        (vec!["--speeds", "1,0"], "speed of device 1 is 0"),
        (vec!["--speeds", "1,,2"], "'' for '--speeds"),
        (vec!["--fail", "7@1"], "fault on device 7"),
        (vec!["--fail", "1"], "'1' for '--fail"),
        (vec!["--latency=-1"], "latency -1"),
        (vec!["--policy", "random"], "unknown policy \"random\""),
    ] {
        let mut all = vec!["schedule", "--costs", good];
        all.extend(args);
        let out = cobalt(&all);
        assert_eq!(out.status.code(), Some(2), "{all:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expected), "{err} lacks {expected}");
    }
    let missing = cobalt(&["schedule", "--costs", "/nonexistent/costs.txt"]);
    assert!(String::from_utf8_lossy(&missing.stderr).contains("/nonexistent/costs.txt"));
}

#[test]
fn schedule_prints_a_readable_table() {
    let file = write_temp("table.txt", "3\n3\n2\n2\n2\n");
    let out = cobalt(&[
        "schedule",
        "--costs",
        file.to_str().unwrap(),
        "--speeds",
        "1,1",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("makespan      7"), "{text}");
    assert!(
        text.contains("| device | speed | tasks | busy | launches |"),
        "{text}"
    );
}
