use std::process::Output;

/// A small forest (~12k triangles): fast in the test profile, still irregular.
const SCENE: &str = "builtin:forest:0.05";

fn cobalt(args: &[&str]) -> Output {
    let mut all = vec!["estimate"];
    all.extend_from_slice(args);
    crate::testkit::cobalt(&all)
}

/// `args` plus each default flag (a pair of words) that `args` does not set itself.
fn with_defaults<'a>(args: &[&'a str], defaults: &[[&'a str; 2]]) -> Vec<&'a str> {
    let mut all = args.to_vec();
    for [flag, value] in defaults {
        if !args.contains(flag) {
            all.extend([*flag, *value]);
        }
    }
    all
}

fn json(args: &[&str]) -> serde_json::Value {
    let mut all = with_defaults(
        args,
        &[
            ["--scene", SCENE],
            ["--size", "64x64"],
            ["--task-size", "512"],
        ],
    );
    all.push("--json");
    let out = cobalt(&all);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

fn num(v: &serde_json::Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is not a number in {v}"))
}

#[test]
fn json_has_the_contract_fields_as_fractions() {
    let v = json(&["--rays", "primary"]);
    assert_eq!(v["ray_kind"], "primary");
    assert_eq!(num(&v, "rays"), 4096.0);
    assert_eq!(num(&v, "task_size"), 512.0);
    assert_eq!(num(&v, "tasks"), 8.0);
    assert_eq!(num(&v, "sample_rate"), 0.125);
    assert_eq!(num(&v, "sampled_rays"), 512.0);
    for key in ["prediction_error", "overhead", "error_vs_time"] {
        let x = num(&v, key);
        // Fractions, not percentages: a 12.5 % sample of a coherent generation is far
        // from 100 % wrong, and its reduced traversal is far cheaper than the trace.
        assert!((0.0..1.0).contains(&x), "{key} = {x}");
    }
    let rho = num(&v, "spearman_vs_time");
    assert!((-1.0..=1.0).contains(&rho) && rho > 0.5, "spearman {rho}");
    assert!(num(&v, "estimate_seconds") > 0.0 && num(&v, "trace_seconds") > 0.0);
    let cal = &v["calibration"];
    assert!(num(cal, "kb") >= 0.0 && num(cal, "kt") >= 0.0 && num(cal, "r2") <= 1.0);
}

/// The trace's own counts: a calibrated fit of them against the measured times is reported
/// beside the estimate's, for closest- and any-hit rays, and the trace never enters more nodes
/// than the reduced traversal, which never shortens a ray.
#[test]
fn the_real_traces_counts_are_fitted_too() {
    for rays in ["primary", "ao"] {
        let v = json(&["--rays", rays]);
        let e = num(&v, "error_vs_time_trace");
        assert!((0.0..1.0).contains(&e), "{rays}: {e}");
        let rho = num(&v, "spearman_trace_vs_time");
        assert!((-1.0..=1.0).contains(&rho), "{rays}: {rho}");
        let (trace, reduced) = (
            num(&v, "trace_nodes_per_ray"),
            num(&v, "reduced_nodes_per_ray"),
        );
        assert!(
            trace > 0.0 && trace <= reduced,
            "{rays}: {trace} vs {reduced}"
        );
        assert!(num(&v, "trace_tris_per_ray") <= num(&v, "reduced_tris_per_ray"));
    }
}

#[test]
fn full_sampling_has_zero_prediction_error() {
    for rays in ["primary", "ao"] {
        let v = json(&[
            "--rays",
            rays,
            "--sample-rate",
            "1",
            "--size",
            "16x16",
            "--repeats",
            "1",
        ]);
        assert_eq!(num(&v, "prediction_error"), 0.0, "{rays}");
        assert_eq!(num(&v, "sampled_rays"), num(&v, "rays"), "{rays}");
    }
}

#[test]
fn ray_files_are_estimated_with_their_kind() {
    let path = crate::testkit::temp_dir("estimate").join("rays.bin");
    let mut bytes = Vec::new();
    for i in 0..100 {
        let x = i as f32 - 50.0;
        for v in [x, 60.0, 0.5 * x, 0.0, -1.0, 0.01 * x, 0.0, 1000.0] {
            bytes.extend_from_slice(&f32::to_le_bytes(v));
        }
    }
    std::fs::write(&path, bytes).expect("temp ray file");
    let file = path.to_str().expect("utf-8 temp path");
    let v = json(&["--rays", file, "--ray-kind", "shadow", "--task-size", "30"]);
    assert_eq!((num(&v, "rays"), num(&v, "tasks")), (100.0, 4.0));
    assert_eq!(v["ray_kind"], "shadow");
}

/// Whitted rays are every generation of a render (primary, shadow, reflection), each cut into
/// its own tasks; at full sampling the estimate is the full count.
#[test]
fn whitted_rays_are_every_generation_of_a_render() {
    let v = json(&[
        "--scene",
        "builtin:cornell:0.2",
        "--rays",
        "whitted",
        "--size",
        "32x32",
    ]);
    assert_eq!(v["ray_kind"], "whitted");
    assert!(
        num(&v, "rays") > 32.0 * 32.0,
        "more than the primary rays: {v}"
    );
    assert!(
        num(&v, "tasks") >= 3.0,
        "one or more tasks per generation: {v}"
    );
    let full = json(&[
        "--scene",
        "builtin:cornell:0.2",
        "--rays",
        "whitted",
        "--size",
        "32x32",
        "--sample-rate",
        "1",
    ]);
    assert_eq!(num(&full, "prediction_error"), 0.0);
}

/// `--walk first-leaf` ends camera rays at their first leaf: fewer nodes per ray than the
/// thesis's walk, reported as such, and still the exact "full" at a sampling rate of 1, also
/// for Whitted's mix of generations (its shadow rays keep the reduced walk).
#[test]
fn the_first_leaf_walk_is_reported_and_enters_fewer_nodes() {
    let thesis = json(&["--rays", "primary", "--walk", "reduced"]);
    let first = json(&["--rays", "primary", "--walk", "first-leaf"]);
    assert_eq!(thesis["walk"], "reduced");
    assert_eq!(first["walk"], "first-leaf");
    let nodes = |v: &serde_json::Value| num(v, "reduced_nodes_per_ray");
    assert!(nodes(&first) < nodes(&thesis), "{first} vs {thesis}");
    let all = json(&[
        "--rays",
        "primary",
        "--walk",
        "first-leaf",
        "--sample-rate",
        "1",
    ]);
    assert_eq!(num(&all, "prediction_error"), 0.0);
    let whitted = |walk| {
        json(&[
            "--rays",
            "whitted",
            "--walk",
            walk,
            "--size",
            "32x32",
            "--sample-rate",
            "1",
        ])
    };
    let (w_thesis, w_first) = (whitted("reduced"), whitted("first-leaf"));
    assert_eq!(num(&w_first, "prediction_error"), 0.0);
    assert!(
        nodes(&w_first) < nodes(&w_thesis),
        "{w_first} vs {w_thesis}"
    );
}

#[test]
fn bad_arguments_exit_2_naming_flag_and_value() {
    let cases: [(&[&str], &[&str]); 14] = [
        (&["--walk", "deepest"], &["--walk", "deepest", "first-leaf"]),
        (&["--sample-error", "1"], &["--sample-error", "`1`", "off"]),
        (&["--sample-error", "some"], &["--sample-error", "`some`"]),
        (&["--sample-run", "0"], &["--sample-run", "0"]),
        (
            &["--clock", "sundial"],
            &["--clock", "sundial", "wall or cpu"],
        ),
        (
            &["--clock", "cpu", "--device", "gpu"],
            &["clock", "cpu", "--device gpu"],
        ),
        (&["--sample-rate", "0"], &["--sample-rate", "0"]),
        (&["--sample-rate", "1.5"], &["--sample-rate", "1.5"]),
        (&["--sample-rate", "lots"], &["--sample-rate", "lots"]),
        (&["--task-size", "0"], &["--task-size", "0"]),
        (&["--size", "64"], &["--size", "64"]),
        (&["--camera", "4"], &["--camera", "4"]),
        (&["--rays", "/no/such/rays.bin"], &["/no/such/rays.bin"]),
        (
            &["--ray-kind", "sideways", "--rays", "x.bin"],
            &["--ray-kind", "sideways"],
        ),
    ];
    for (args, needles) in cases {
        let all = with_defaults(
            args,
            &[
                ["--scene", SCENE],
                ["--size", "16x16"],
                ["--rays", "primary"],
            ],
        );
        let out = cobalt(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(out.stdout.is_empty(), "{args:?} printed output");
        for n in needles {
            assert!(err.contains(n), "{args:?}: {err:?} does not name {n}");
        }
    }
}

/// `--device gpu` samples, compacts, traverses and sums on the GPU, and its estimates are the
/// CPU's: the same prediction errors to the bit, for primary, AO and Whitted rays, with either
/// walk. Without any
/// adapter: a note, or a failure when `CI` is set. A task beyond the GPU's limit is refused,
/// naming `--task-size`.
#[test]
fn gpu_estimates_equal_cpu_estimates() {
    let run = |args: &[&str]| {
        let all = with_defaults(
            args,
            &[
                ["--scene", SCENE],
                ["--size", "48x48"],
                ["--task-size", "300"],
                ["--ao-samples", "4"],
                ["--repeats", "1"],
                // The GPU estimator samples every task at its rate: so does the CPU's here.
                ["--sample-error", "off"],
            ],
        );
        let mut cmd = crate::testkit::command();
        cmd.env("COBALT_GPU_SOFTWARE", "1")
            .arg("estimate")
            .args(all);
        cmd.arg("--json").output().expect("the cobalt binary runs")
    };
    for (rays, walk) in [
        ("primary", "reduced"),
        ("ao", "reduced"),
        ("whitted", "reduced"),
        ("primary", "first-leaf"),
        ("whitted", "first-leaf"),
    ] {
        let cpu = run(&["--rays", rays, "--walk", walk]);
        assert!(
            cpu.status.success(),
            "{}",
            String::from_utf8_lossy(&cpu.stderr)
        );
        let gpu = run(&["--rays", rays, "--walk", walk, "--device", "gpu"]);
        let err = String::from_utf8_lossy(&gpu.stderr);
        if err.contains("no GPU adapter") {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI is set but no GPU adapter was found: {err}"
            );
            eprintln!("note: no GPU adapter here; the GPU estimator was not checked");
            return;
        }
        assert!(gpu.status.success(), "{err}");
        let parse = |o: &Output| -> serde_json::Value {
            serde_json::from_slice(&o.stdout).expect("one JSON object")
        };
        let (c, g) = (parse(&cpu), parse(&gpu));
        assert_eq!(
            (c["device"].as_str(), g["device"].as_str()),
            (Some("cpu"), Some("gpu"))
        );
        assert!(g["adapter"].is_string(), "{g}");
        for key in [
            "prediction_error",
            "prediction_error_nodes",
            "prediction_error_tris",
            "sampled_rays",
            "tasks",
        ] {
            assert_eq!(c[key], g[key], "{rays} {walk}: {key}");
        }
        assert_eq!(g["walk"], walk);
        assert!(num(&g, "prediction_error") > 0.0, "{rays} {walk}: {g}");
    }
    // One task longer than the 46 340 rays the device's sample arithmetic once allowed: the
    // GPU samples it as the CPU does.
    let long = [
        "--rays",
        "primary",
        "--size",
        "256x256",
        "--task-size",
        "50000",
        "--walk",
        "reduced",
    ];
    let (c, g) = (run(&long), run(&[&long[..], &["--device", "gpu"]].concat()));
    assert!(g.status.success(), "{}", String::from_utf8_lossy(&g.stderr));
    let parse = |o: &Output| -> serde_json::Value {
        serde_json::from_slice(&o.stdout).expect("one JSON object")
    };
    let (c, g) = (parse(&c), parse(&g));
    assert!(c["rays"].as_u64().is_some_and(|n| n > 50_000), "{c}");
    for key in ["prediction_error", "sampled_rays", "tasks"] {
        assert_eq!(c[key], g[key], "tasks of 50000 rays: {key}");
    }
    // The trace walk runs on the CPU only, and the GPU says so.
    let refused = run(&["--rays", "primary", "--walk", "trace", "--device", "gpu"]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && err.contains("`trace`"),
        "{err}"
    );
}

/// `--walk trace` traces the sample for real: its estimate of a full sample is the trace's
/// own counts, and the overhead net of the sampled rays (which a render does not trace
/// again) is reported beside the gross one.
#[test]
fn the_trace_walk_reports_its_net_overhead() {
    for rays in ["primary", "ao"] {
        let v = json(&["--rays", rays, "--walk", "trace"]);
        assert_eq!(v["walk"], "trace");
        let (gross, net) = (num(&v, "overhead"), num(&v, "net_overhead"));
        let (full, rest) = (num(&v, "trace_seconds"), num(&v, "rest_seconds"));
        assert!(
            gross > 0.0 && rest > 0.0 && full > 0.0 && net.is_finite(),
            "{v}"
        );
        // The trace and the rest were cut in slices (one for a batch this small).
        let slices = v["slices"].as_u64().unwrap_or(0);
        assert!((1..=16).contains(&slices), "{v}");
        // The median lies in the pairs' middle half.
        let q = &v["net_overhead_quartiles"];
        let (q1, q3) = (q[0].as_f64().unwrap(), q[1].as_f64().unwrap());
        assert!(q1 <= net && net <= q3, "{v}");
        // A sample of every ray leaves the rest nothing to trace: each round's net overhead
        // is its overhead less the whole trace, plus the rest's walk over the known rays (at
        // least nothing, at most a fraction of a trace), and so are their medians.
        let full_sample = json(&["--rays", rays, "--walk", "trace", "--sample-rate", "1"]);
        let (gross, net) = (
            num(&full_sample, "overhead"),
            num(&full_sample, "net_overhead"),
        );
        assert!(
            net >= gross - 1.0 - 1e-9 && net < gross - 0.5,
            "{full_sample}"
        );
        assert_eq!(num(&full_sample, "prediction_error"), 0.0);
        assert_eq!(
            full_sample["error_vs_time_full"], full_sample["error_vs_time_trace"],
            "the full trace walk is the trace's own counts"
        );
    }
    // A reduced walk's sample is wasted: its net overhead is its overhead.
    let thesis = json(&["--rays", "primary", "--walk", "reduced"]);
    assert!(thesis.get("rest_seconds").is_none(), "{thesis}");
    assert_eq!(thesis["net_overhead"], thesis["overhead"]);
}

/// `--sample-run` keeps as many samples in longer runs, and `--clock cpu` times every step on
/// the process's CPU time; both are reported.
#[test]
fn the_sample_run_and_the_clock_are_reported() {
    let pairs = json(&[
        "--rays",
        "primary",
        "--sample-run",
        "2",
        "--sample-error",
        "off",
    ]);
    let runs = json(&[
        "--rays",
        "primary",
        "--clock",
        "cpu",
        "--sample-error",
        "off",
    ]);
    assert_eq!(
        (pairs["sample_run"].as_u64(), runs["sample_run"].as_u64()),
        (Some(2), Some(8))
    );
    assert_eq!(
        (pairs["clock"].as_str(), runs["clock"].as_str()),
        (Some("wall"), Some("cpu"))
    );
    assert_eq!(pairs["sampled_rays"], runs["sampled_rays"]);
    for key in [
        "estimate_seconds",
        "trace_seconds",
        "rest_seconds",
        "net_overhead",
    ] {
        assert!(
            runs[key].as_f64().is_some_and(f64::is_finite),
            "{key}: {runs}"
        );
    }
    assert!(num(&runs, "trace_seconds") > 0.0, "{runs}");
    // A trace this short is timed in more rounds than asked for, up to 128, in whole pairs.
    let (repeats, rounds) = (num(&runs, "repeats"), num(&runs, "rounds"));
    assert!(
        repeats < rounds && rounds <= 128.0 && rounds % 2.0 == 0.0,
        "{runs}"
    );
    // What each walk's estimates buy a plan, framed by the measured times and by none.
    let (best, none) = (
        num(&pairs, "balance_measured"),
        num(&pairs, "balance_uniform"),
    );
    assert!(
        best > 0.0 && best <= 1.0 + 1e-12 && none > 0.0 && none <= best + 1e-12,
        "{pairs}"
    );
    for w in pairs["walks"].as_array().expect("walks") {
        let b = num(w, "lpt_balance");
        assert!(b > 0.0 && b <= 1.0 + 1e-12, "{w}");
    }
    assert_eq!(pairs["balance_devices"], 8);
}

/// `--sample-error` refines the sample: on tasks of 4096 rays it starts at a quarter of the
/// rate and stops there when its halves agree within a loose target, grows to the whole rate
/// for a target no sample meets, and is reported; `off` takes the whole sample at once.
#[test]
fn a_refined_sample_is_reported_with_the_rays_it_took() {
    let run = |error: &str| {
        json(&[
            "--rays",
            "primary",
            "--size",
            "128x128",
            "--task-size",
            "4096",
            "--sample-error",
            error,
        ])
    };
    let (loose, tight, off) = (run("0.99"), run("0.000001"), run("off"));
    assert_eq!(num(&loose, "sample_error"), 0.99);
    assert!(off["sample_error"].is_null(), "{off}");
    // Four tasks of 512 samples: 128 each at a quarter. A target no sample meets grows every
    // task whose halves disagree at all (a task of sky, every ray alike, does not grow).
    assert_eq!(num(&loose, "sampled_rays"), 512.0);
    assert_eq!(num(&off, "sampled_rays"), 2048.0);
    let grown = num(&tight, "sampled_rays");
    assert!(grown > 512.0 && grown <= 2048.0, "{tight}");
    for v in [&loose, &tight] {
        assert!(num(v, "net_overhead").is_finite(), "{v}");
    }
}

/// On the CPU the trace walk is the default, the report leads with the figures judged by
/// time, and every walk's trade is timed beside the chosen one's.
#[test]
fn estimates_are_judged_by_time_with_every_walk_beside() {
    let out = cobalt(&[
        "--scene",
        SCENE,
        "--size",
        "64x64",
        "--task-size",
        "512",
        "--rays",
        "primary",
        "--json",
    ]);
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    let at = |key: &str| text.find(&format!("\"{key}\"")).unwrap_or(usize::MAX);
    let order = [
        "error_vs_time",
        "spearman_vs_time",
        "error_vs_time_trace",
        "spearman_trace_vs_time",
        "net_overhead",
        "scene",
    ];
    assert!(order.windows(2).all(|w| at(w[0]) < at(w[1])), "{text}");
    let v: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    assert_eq!(v["walk"], "trace");
    let walks = v["walks"].as_array().expect("every walk's trade");
    let names: Vec<&str> = walks.iter().filter_map(|p| p["walk"].as_str()).collect();
    assert_eq!(names, ["trace", "reduced", "first-leaf"]);
    let trace = &walks[0];
    assert_eq!(trace["error_vs_time"], v["error_vs_time"]);
    assert_eq!(trace["net_overhead"], v["net_overhead"]);
}
