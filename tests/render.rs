use std::path::Path;

use crate::testkit::cobalt;

/// Width and height from a PNG's signature and IHDR chunk, after checking it ends with IEND.
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).expect("the PNG was written");
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{}", path.display());
    assert_eq!(&b[12..16], b"IHDR");
    assert_eq!(
        &b[b.len() - 8..b.len() - 4],
        b"IEND",
        "{} is complete",
        path.display()
    );
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

#[test]
fn render_writes_the_image_the_cost_image_and_the_report() {
    let dir = crate::testkit::temp_dir("render");
    let (out, cost, report) = (dir.join("x.png"), dir.join("c.png"), dir.join("r.json"));
    for shader in ["whitted", "ao"] {
        let o = cobalt(&[
            "render",
            "--pipeline",
            "generations",
            "--scene",
            "builtin:cornell",
            "--shader",
            shader,
            "--size",
            "32x24",
            "--devices",
            "cpu:2",
            "--out",
            out.to_str().unwrap(),
            "--cost-image",
            cost.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(png_size(&out), (32, 24));
        assert_eq!(png_size(&cost), (64, 24), "B and T side by side");
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&report).unwrap()).expect("JSON report");
        assert_eq!(v["scene"], "builtin:cornell");
        assert_eq!(v["shader"], shader);
        assert_eq!(v["size"], "32x24");
        assert_eq!(v["threads"], 2);
        let gens = v["generations"].as_array().unwrap();
        assert_eq!(gens[0]["kind"], "primary");
        assert_eq!(gens[0]["rays"], 32 * 24);
        let total: u64 = gens.iter().map(|g| g["rays"].as_u64().unwrap()).sum();
        assert_eq!(v["total_rays"].as_u64().unwrap(), total);
        assert!(gens.iter().all(|g| g["seconds"].as_f64().unwrap() >= 0.0));
        assert!(v["mrays_per_s"].as_f64().unwrap() > 0.0);
        assert!(v["cost"]["max_nodes"].as_u64().unwrap() > 0);
        let kinds: Vec<&str> = gens.iter().map(|g| g["kind"].as_str().unwrap()).collect();
        if shader == "whitted" {
            assert!(
                kinds.contains(&"shadow") && kinds.contains(&"reflection"),
                "{kinds:?}"
            );
        } else {
            assert_eq!(kinds, ["primary", "ao"]);
            assert_eq!(v["ao_samples"], 32);
        }
        // The default pipeline renders by paths and counts the same cost image on the host.
        let (out2, cost2) = (dir.join("x2.png"), dir.join("c2.png"));
        let o = cobalt(&[
            "render",
            "--scene",
            "builtin:cornell",
            "--shader",
            shader,
            "--size",
            "32x24",
            "--out",
            out2.to_str().unwrap(),
            "--cost-image",
            cost2.to_str().unwrap(),
            "--json",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
        assert_eq!(v["pipeline"], "paths");
        assert_eq!(std::fs::read(&out2).unwrap(), std::fs::read(&out).unwrap());
        assert_eq!(
            std::fs::read(&cost2).unwrap(),
            std::fs::read(&cost).unwrap()
        );
    }
}

#[test]
fn bad_arguments_exit_2_naming_the_value_and_write_nothing() {
    let dir = crate::testkit::temp_dir("render-bad");
    let (out, cost, report) = (dir.join("x.png"), dir.join("c.png"), dir.join("r.json"));
    for (flag, value) in [
        ("--size", "0x32"),
        ("--size", "32"),
        ("--size", "32xlots"),
        ("--camera", "4"),
        ("--camera", "-1"),
        ("--devices", "gpu:first"),
        ("--devices", "cpu:0"),
        ("--devices", "tpu"),
        ("--ao-samples", "0"),
        ("--eye", "1,2"),
        ("--policy", "round-robin"),
        ("--mode", "guess"),
        ("--walk", "deepest"),
        ("--task-size", "0"),
        ("--task-size", "many"),
        ("--sample-rate", "0"),
        ("--sample-rate", "1.5"),
        ("--sample-error", "1.5"),
        // The generations pipeline's, given to the path pipeline (the default).
        ("--sample-error", "0.06"),
        ("--devices", "cpu:1,gpu"),
        ("--devices", "cpu:2/0"),
        ("--fail", "2@1"),
        ("--fail", "1"),
        ("--fail", "0@x"),
    ] {
        let mut args = vec![
            "render",
            "--scene",
            "builtin:cornell",
            "--size",
            "16x16",
            "--out",
            out.to_str().unwrap(),
            "--cost-image",
            cost.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ];
        if flag != "--size" {
            args.extend([flag, value]);
        } else {
            args[4] = value;
        }
        if flag == "--eye" {
            args.extend(["--at", "0,0,0"]);
        }
        let o = cobalt(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {err}");
        assert!(err.contains(value), "{flag} {value}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        for p in [&out, &cost, &report] {
            assert!(!p.exists(), "{flag} {value} left {}", p.display());
        }
    }
}

/// Runs `cobalt render` on a small Cornell box and returns the PNG bytes and the JSON report.
fn render_with(tag: &str, shader: &str, extra: &[&str]) -> (Vec<u8>, serde_json::Value) {
    let dir = crate::testkit::temp_dir("render-sched");
    let (out, report) = (
        dir.join(format!("{tag}.png")),
        dir.join(format!("{tag}.json")),
    );
    let mut args = vec![
        "render",
        "--pipeline",
        "generations",
        "--scene",
        "builtin:cornell",
        "--shader",
        shader,
        "--ao-samples",
        "8",
        "--size",
        "32x32",
        "--task-size",
        "128",
        "--out",
        out.to_str().expect("a UTF-8 temp path"),
        "--report",
        report.to_str().expect("a UTF-8 temp path"),
    ];
    args.extend_from_slice(extra);
    let o = cobalt(&args);
    assert!(
        o.status.success(),
        "{extra:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let png = std::fs::read(&out).expect("the PNG was written");
    let v = serde_json::from_slice(&std::fs::read(&report).expect("the report was written"))
        .expect("JSON report");
    (png, v)
}

#[test]
fn every_policy_mode_and_device_list_renders_the_same_image() {
    for shader in ["whitted", "ao"] {
        let (want, _) = render_with("ref", shader, &["--devices", "cpu:1", "--mode", "regular"]);
        for policy in [
            "static-equal",
            "static-lpt",
            "queue-fifo",
            "queue-sorted",
            "hybrid",
        ] {
            for mode in ["regular", "cost"] {
                for devices in ["cpu:2", "cpu:1/2,cpu:1"] {
                    let tag = format!("{shader}-{policy}-{mode}-{}", devices.len());
                    let (png, v) = render_with(
                        &tag,
                        shader,
                        &["--policy", policy, "--mode", mode, "--devices", devices],
                    );
                    assert!(png == want, "{tag}: the image differs");
                    assert_eq!(v["policy"], policy);
                    assert_eq!(v["mode"], mode);
                    assert_eq!(v["task_size"], 128);
                    assert_eq!(v["device_names"].as_array().unwrap().len(), 2, "{tag}");
                    let balance = v["balance_efficiency"].as_f64().unwrap();
                    assert!(balance > 0.0 && balance <= 1.0 + 1e-9, "{tag}");
                    for g in v["generations"].as_array().unwrap() {
                        let rays = g["rays"].as_u64().unwrap();
                        // 128 rays a task, or, where a generation is too small to give
                        // each of the 2 devices 4 tasks, 16 tasks each (not below 64 rays).
                        let size = g["task_size"].as_u64().unwrap();
                        let want = if rays >= 2 * 4 * 128 {
                            128
                        } else {
                            128.min(rays.div_ceil(32).max(64))
                        };
                        assert_eq!(size, want.min(rays), "{tag}");
                        assert_eq!(g["tasks"].as_u64().unwrap(), rays.div_ceil(want), "{tag}");
                        assert!(g["balance_efficiency"].as_f64().is_some(), "{tag}");
                        assert!(g["plan_seconds"].as_f64().unwrap() >= 0.0, "{tag}");
                        assert_eq!(g["speeds"].as_array().unwrap().len(), 2, "{tag}");
                        let launches = g["launches"].as_array().unwrap();
                        if policy.starts_with("static") {
                            assert!(launches.iter().all(|l| l.as_u64().unwrap() <= 1), "{tag}");
                        }
                    }
                    if mode == "cost" {
                        let cal = v["calibration"].as_array().unwrap();
                        assert!(!cal.is_empty(), "{tag}");
                        assert!(cal.iter().all(|c| c["kb"].as_f64().unwrap() >= 0.0
                            && c["kt"].as_f64().unwrap() >= 0.0));
                    }
                }
            }
        }
    }
}

/// `--walk first-leaf` and `--walk trace` plan with their walk and say so; the image is
/// the reduced walk's, whatever the shader (the trace walk's sampled hits stand in for the
/// devices' trace of those rays).
#[test]
fn every_walk_renders_the_same_image() {
    for shader in ["whitted", "ao"] {
        let base = ["--devices", "cpu:2", "--policy", "hybrid"];
        let (want, thesis) = render_with(&format!("{shader}-thesis"), shader, &base);
        assert_eq!(thesis["walk"], "reduced");
        assert!(thesis["sample_error"].is_null(), "{thesis}");
        for (walk, error) in [("first-leaf", "off"), ("trace", "off"), ("trace", "0.06")] {
            let mut args = base.to_vec();
            args.extend(["--walk", walk, "--sample-error", error]);
            let (png, got) = render_with(&format!("{shader}-{walk}-{error}"), shader, &args);
            assert!(png == want, "{shader}, {walk}, {error}: the image differs");
            assert_eq!(got["walk"], walk);
            match error {
                "off" => assert!(got["sample_error"].is_null(), "{got}"),
                e => assert_eq!(got["sample_error"].as_f64(), e.parse().ok()),
            }
        }
    }
}

#[test]
fn a_failing_device_is_reported_and_the_image_is_still_complete() {
    let (want, _) = render_with("ok", "whitted", &["--devices", "cpu:2"]);
    let (png, v) = render_with(
        "fail",
        "whitted",
        &[
            "--devices",
            "cpu:2",
            "--policy",
            "static-equal",
            "--fail",
            "1@1",
        ],
    );
    assert!(png == want, "the image differs after a failure");
    assert!(v["reruns"].as_u64().unwrap() > 0, "{v}");
    let first = &v["generations"][0];
    assert!(
        first["failures"][0]
            .as_str()
            .unwrap()
            .contains("injected fault")
    );
    // Later generations run on the survivor alone.
    assert_eq!(
        v["generations"][1]["device_names"],
        serde_json::json!(["cpu0"])
    );
}

/// A CPU and a GPU render one image together, equal to the CPU's alone (software adapters
/// allowed, so lavapipe counts). Without any adapter: a note, or a failure when `CI` is set.
#[test]
fn cpu_and_gpu_render_the_cpu_image() {
    let dir = crate::testkit::temp_dir("render-gpu");
    let run = |devices: &str, policy: &str, extra: &[&str]| {
        let tag = format!(
            "{}-{policy}-{}",
            devices.replace([':', ','], "_"),
            extra.len()
        );
        let out = dir.join(format!("{tag}.png"));
        let o = crate::testkit::command()
            .env("COBALT_GPU_SOFTWARE", "1")
            .args([
                "render",
                "--pipeline",
                "generations",
                "--scene",
                "builtin:cornell",
                "--size",
                "32x32",
                "--task-size",
            ])
            .args(["128", "--policy", policy, "--devices", devices, "--out"])
            .arg(&out)
            .args(extra)
            .output()
            .expect("the cobalt binary runs");
        (o, out)
    };
    for policy in ["static-lpt", "hybrid"] {
        let (cpu, cpu_png) = run("cpu:2", policy, &[]);
        assert!(
            cpu.status.success(),
            "{}",
            String::from_utf8_lossy(&cpu.stderr)
        );
        let (mixed, mixed_png) = run("cpu:1,gpu:all", policy, &[]);
        let err = String::from_utf8_lossy(&mixed.stderr);
        if err.contains("no GPU adapter") {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI is set but no GPU adapter was found: {err}"
            );
            eprintln!("note: no GPU adapter here; the CPU+GPU render was not checked");
            return;
        }
        assert!(mixed.status.success(), "{err}");
        let (a, b) = (std::fs::read(&cpu_png), std::fs::read(mixed_png));
        assert_eq!(a.expect("cpu png"), b.expect("mixed png"), "{policy}");

        // The estimate on the GPU: the same image, and the report says where it ran.
        let report = dir.join(format!("estimate-on-gpu-{policy}.json"));
        let report_arg = report.to_str().expect("a UTF-8 temp path");
        let extra = ["--estimate-on", "gpu", "--report", report_arg];
        let (on_gpu, on_gpu_png) = run("cpu:1,gpu:all", policy, &extra);
        let err = String::from_utf8_lossy(&on_gpu.stderr);
        assert!(on_gpu.status.success(), "{err}");
        let (a, b) = (std::fs::read(&cpu_png), std::fs::read(on_gpu_png));
        assert_eq!(
            a.expect("cpu png"),
            b.expect("png"),
            "{policy} --estimate-on gpu"
        );
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("JSON");
        for g in v["generations"].as_array().expect("generations") {
            assert_eq!(g["estimated_on"], "gpu0", "{policy}: {g}");
            // Rays made on the host cross to the GPU: at least the estimate's sample of
            // 32-byte rays goes up, its sums come back, and the host waits for them.
            let bytes = |k: &str| g[k].as_u64().expect(k);
            assert!(bytes("host_to_device_bytes") >= 32, "{policy}: {g}");
            assert!(bytes("device_to_host_bytes") >= 16, "{policy}: {g}");
            assert!(bytes("host_waits") >= 1, "{policy}: {g}");
        }
    }
}

/// `--pipeline paths` renders whole paths on the devices through `sched`: on `cpu:2` under
/// every policy it writes the generation pipeline's image byte for byte and moves nothing;
/// `--pipeline gpu` (paths on `gpu:0`) and a CPU and a GPU together write it too (at most 1 %
/// of pixels may differ, see `raytrace::gpu::GpuRenderer`; on lavapipe they are equal), with
/// a GPU's traffic bounded by its tasks. Without any adapter: a note, or a failure when `CI`
/// is set. The generation pipeline's flags are refused with it, naming the flag, and so is
/// `--repeats` without it.
#[test]
fn the_path_pipeline_renders_the_cpu_image() {
    let dir = crate::testkit::temp_dir("render-paths");
    let run = |shader: &str, extra: &[&str], name: &str| {
        let out = dir.join(name);
        let o = crate::testkit::command()
            .env("COBALT_GPU_SOFTWARE", "1")
            .args(["render", "--scene", "builtin:cornell", "--shader", shader])
            .args(["--size", "40x24", "--ao-samples", "4", "--json", "--out"])
            .arg(&out)
            .args(extra)
            .output()
            .expect("the cobalt binary runs");
        (o, out)
    };
    let load = |p: &Path| image::open(p).expect("PNG").to_rgb8().into_raw();
    for shader in ["ao", "whitted"] {
        let (cpu, cpu_png) = run(
            shader,
            &["--pipeline", "generations", "--devices", "cpu:2"],
            &format!("cpu-{shader}.png"),
        );
        assert!(
            cpu.status.success(),
            "{}",
            String::from_utf8_lossy(&cpu.stderr)
        );
        let reference = load(&cpu_png);
        for policy in ["static-lpt", "queue-sorted", "hybrid"] {
            let (o, png) = run(
                shader,
                &[
                    "--pipeline",
                    "paths",
                    "--devices",
                    "cpu:2",
                    "--policy",
                    policy,
                ],
                &format!("paths-{shader}-{policy}.png"),
            );
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON report");
            assert_eq!(v["pipeline"], "paths");
            assert_eq!(v["paths"], 40 * 24);
            assert_eq!(v["host_to_device_bytes"], 0);
            assert_eq!(v["film_bytes"], 0);
            assert_eq!(load(&png), reference, "{shader} {policy}");
        }
        for (name, extra) in [
            ("gpu", &["--pipeline", "gpu", "--repeats", "2"][..]),
            (
                "mixed",
                &[
                    "--pipeline",
                    "paths",
                    "--devices",
                    "cpu:1,gpu:0",
                    "--policy",
                    "hybrid",
                ][..],
            ),
        ] {
            let (gpu, gpu_png) = run(shader, extra, &format!("{name}-{shader}.png"));
            let err = String::from_utf8_lossy(&gpu.stderr);
            if err.contains("no GPU adapter") {
                assert!(
                    std::env::var_os("CI").is_none(),
                    "CI is set but no GPU adapter was found: {err}"
                );
                eprintln!("note: no GPU adapter here; the GPU path pipeline was not checked");
                return;
            }
            assert!(gpu.status.success(), "{err}");
            let v: serde_json::Value = serde_json::from_slice(&gpu.stdout).expect("JSON report");
            assert_eq!(v["shader"], shader);
            let tasks = v["tasks"].as_u64().expect("tasks");
            let bytes = v["host_to_device_bytes"].as_u64().expect("bytes")
                + v["device_to_host_bytes"].as_u64().expect("bytes");
            let launches = v["launches"].as_u64().expect("launches");
            // Per launch: its parameters and the trace queues' state; per task: its entry.
            assert!(bytes <= 1024 * launches + 64 * tasks, "{name}: {bytes} B");
            if name == "gpu" {
                assert_eq!(v["pipeline"], "gpu");
                assert_eq!(v["frames"], 2);
                let seconds = |k: &str| v[k].as_f64().expect(k);
                assert!(seconds("render_seconds") <= seconds("first_render_seconds"));
            }
            let b = load(&gpu_png);
            assert_eq!(reference.len(), b.len());
            let differ = reference
                .chunks(3)
                .zip(b.chunks(3))
                .filter(|(x, y)| x != y)
                .count();
            eprintln!("{name} {shader}: {differ} pixels differ from the CPU's");
            assert!(
                differ * 100 <= reference.len() / 3,
                "{name} {shader}: {differ} pixels differ"
            );
        }
    }
    for (extra, flag) in [
        (&["gpu", "--walk", "trace"][..], "--walk"),
        (&["paths", "--estimate-on", "gpu"][..], "--estimate-on"),
        (&["generations", "--repeats", "2"][..], "--repeats"),
    ] {
        let o = crate::testkit::command()
            .args(["render", "--scene", "builtin:cornell", "--size", "8x8"])
            .args(["--shader", "ao", "--pipeline"])
            .args(extra)
            .output()
            .expect("the cobalt binary runs");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(flag), "{flag}: {err}");
    }
}

/// `--fail 1@1` on a GPU (device 1 of `cpu:1,gpu:all`): the GPU fails after one task, its
/// tasks are re-run on the CPU, the report names the fault, and the image is the CPU's.
/// Without any adapter: a note, or a failure when `CI` is set.
#[test]
fn a_failing_gpu_is_reported_and_the_image_is_still_complete() {
    let dir = crate::testkit::temp_dir("render-gpu-fail");
    let run = |devices: &str, extra: &[&str], name: &str| {
        let out = dir.join(name);
        let o = crate::testkit::command()
            .env("COBALT_GPU_SOFTWARE", "1")
            .args(["render", "--scene", "builtin:cornell", "--shader", "ao"])
            .args([
                "--pipeline",
                "generations",
                "--size",
                "32x32",
                "--ao-samples",
                "4",
            ])
            .args(["--task-size", "128", "--policy", "static-equal", "--json"])
            .args(["--devices", devices])
            .args(extra)
            .arg("--out")
            .arg(&out)
            .output()
            .expect("the cobalt binary runs");
        (o, out)
    };
    let (cpu, cpu_png) = run("cpu:1", &[], "cpu.png");
    assert!(
        cpu.status.success(),
        "{}",
        String::from_utf8_lossy(&cpu.stderr)
    );
    let (gpu, gpu_png) = run("cpu:1,gpu:all", &["--fail", "1@1"], "fail.png");
    let err = String::from_utf8_lossy(&gpu.stderr);
    if err.contains("no GPU adapter") {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but no GPU adapter was found: {err}"
        );
        eprintln!("note: no GPU adapter here; the failing GPU was not checked");
        return;
    }
    assert!(gpu.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&gpu.stdout).expect("JSON report");
    assert!(v["reruns"].as_u64().unwrap() > 0, "{v}");
    let first = &v["generations"][0]["failures"][0];
    let reason = first.as_str().unwrap_or_default();
    assert!(
        reason.contains("gpu0") && reason.contains("injected fault"),
        "{v}"
    );
    assert_eq!(
        std::fs::read(cpu_png).expect("cpu png"),
        std::fs::read(gpu_png).expect("gpu png")
    );
}
