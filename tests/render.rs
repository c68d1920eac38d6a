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
        assert_eq!(v["paths"], 32 * 24);
        assert!(v["total_rays"].as_u64().unwrap() >= 32 * 24);
        assert!(v["mrays_per_s"].as_f64().unwrap() > 0.0);
        assert_eq!(v["device_list"], "cpu:2");
        assert_eq!(v["devices"].as_array().unwrap().len(), 2, "{v}");
        if shader == "ao" {
            assert_eq!(v["ao_samples"], 32);
        }
        // One device in regular mode plans nothing: the same image.
        let (out2, cost2) = (dir.join("x2.png"), dir.join("c2.png"));
        let o = cobalt(&[
            "render",
            "--scene",
            "builtin:cornell",
            "--shader",
            shader,
            "--size",
            "32x24",
            "--devices",
            "cpu:1",
            "--mode",
            "regular",
            "--out",
            out2.to_str().unwrap(),
            "--cost-image",
            cost2.to_str().unwrap(),
            "--json",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
        assert_eq!(v["mode"], "regular");
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
        ("--task-size", "0"),
        ("--task-size", "many"),
        ("--sample-rate", "0"),
        ("--sample-rate", "1.5"),
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
                    assert_eq!(v["task_size"], 128, "{tag}");
                    assert_eq!(v["tasks"], 8, "{tag}");
                    assert_eq!(v["devices"].as_array().unwrap().len(), 2, "{tag}");
                    let balance = v["balance_efficiency"].as_f64().unwrap();
                    assert!(balance > 0.0 && balance <= 1.0 + 1e-9, "{tag}");
                    assert!(v["plan_seconds"].as_f64().unwrap() >= 0.0, "{tag}");
                    // A static plan launches once per device, besides backup copies.
                    if policy.starts_with("static") && v["copies"] == 0 {
                        let launches = v["devices"].as_array().unwrap();
                        assert!(
                            launches
                                .iter()
                                .all(|d| d["launches"].as_u64().unwrap() <= 1),
                            "{tag}"
                        );
                    }
                }
            }
        }
    }
}

/// A frame too small to give every device four tasks of `--task-size` paths is cut finer, and
/// the report says so: the task size and the number of tasks it prints are the ones the frame
/// was cut into (`task_size × tasks ≥ paths > task_size × (tasks − 1)`), on one device or
/// several, in the JSON and in the summary.
#[test]
fn the_report_gives_the_task_size_the_frame_was_cut_into() {
    for (size, task_size, devices) in [
        ("32x32", "128", "cpu:2"),
        ("32x32", "512", "cpu:2"),
        ("128x128", "4096", "cpu:2"),
        ("40x24", "4096", "cpu:1"),
        ("7x5", "16", "cpu:3"),
    ] {
        let tag = format!("cut-{size}-{task_size}-{devices}");
        let (w, h) = size.split_once('x').unwrap();
        let paths = w.parse::<u64>().unwrap() * h.parse::<u64>().unwrap();
        let v = cut(&[
            "--task-size",
            task_size,
            "--devices",
            devices,
            "--size",
            size,
        ]);
        let (size, tasks) = (
            v["task_size"].as_u64().unwrap(),
            v["tasks"].as_u64().unwrap(),
        );
        assert_eq!(v["paths"], paths, "{tag}");
        assert!(
            size * tasks >= paths && paths > size * (tasks - 1),
            "{tag}: tasks of {size} × {tasks} for {paths} paths"
        );
        assert!(size <= task_size.parse().unwrap(), "{tag}");
        assert_eq!(
            v["requested_task_size"],
            task_size.parse::<u64>().unwrap(),
            "{tag}"
        );
    }
    // 32 × 32 paths on two devices, asked for tasks of 512: cut down to the floor of 64 paths
    // a task, 16 tasks, in the JSON and in the summary.
    let small = [
        "--task-size",
        "512",
        "--devices",
        "cpu:2",
        "--size",
        "32x32",
    ];
    let v = cut(&small);
    assert_eq!(
        (v["task_size"].as_u64(), v["tasks"].as_u64()),
        (Some(64), Some(16))
    );
    let out = crate::testkit::temp_dir("render-cut").join("summary.png");
    let mut args = vec![
        "render",
        "--scene",
        "builtin:cornell",
        "--no-calibration",
        "--out",
    ];
    args.push(out.to_str().expect("a UTF-8 temp path"));
    args.extend(small);
    let o = cobalt(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("16 tasks of 64 paths"), "{text}");
}

/// `cobalt render --json` of a small AO frame of the Cornell box with `extra` flags.
fn cut(extra: &[&str]) -> serde_json::Value {
    let dir = crate::testkit::temp_dir("render-cut");
    let out = dir.join("cut.png");
    let mut args = vec!["render", "--scene", "builtin:cornell", "--shader", "ao"];
    args.extend(["--ao-samples", "2", "--json", "--no-calibration", "--out"]);
    args.push(out.to_str().expect("a UTF-8 temp path"));
    args.extend_from_slice(extra);
    let o = cobalt(&args);
    assert!(
        o.status.success(),
        "{extra:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
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
            // Backup copies could take device 1's tasks before it reaches its fault.
            "--no-backups",
        ],
    );
    assert!(png == want, "the image differs after a failure");
    assert!(v["reruns"].as_u64().unwrap() > 0, "{v}");
    let failure = v["failures"][0].as_str().unwrap();
    assert!(
        failure.contains("cpu1") && failure.contains("injected fault"),
        "{v}"
    );
}

/// Whole paths are rendered on the devices through `sched`: on `cpu:2` under every policy the
/// image is one CPU device's byte for byte and nothing moves; `gpu:0` alone and a CPU and a
/// GPU together write it too (at most 1 % of pixels may differ, see
/// `raytrace::gpu::GpuRenderer`; on lavapipe they are equal), with a GPU's traffic bounded by
/// its tasks. Without any adapter: a note, or a failure when `CI` is set.
#[test]
fn cpu_gpu_and_mixed_devices_render_the_cpu_image() {
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
            &["--devices", "cpu:1", "--mode", "regular"],
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
                &["--devices", "cpu:2", "--policy", policy],
                &format!("paths-{shader}-{policy}.png"),
            );
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON report");
            assert_eq!(v["paths"], 40 * 24);
            assert_eq!(v["host_to_device_bytes"], 0);
            assert_eq!(v["film_bytes"], 0);
            assert_eq!(load(&png), reference, "{shader} {policy}");
        }
        for (name, extra) in [
            ("gpu", &["--devices", "gpu:0", "--repeats", "2"][..]),
            (
                "mixed",
                &["--devices", "cpu:1,gpu:0", "--policy", "hybrid"][..],
            ),
            // The thesis's walk, estimated on the GPU listed first and on the CPU alike.
            (
                "mixed-reduced",
                &[
                    "--devices",
                    "gpu:0,cpu:1",
                    "--policy",
                    "hybrid",
                    "--walk",
                    "reduced",
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
                eprintln!("note: no GPU adapter here; the GPU renders were not checked");
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
            .args(["--size", "32x32", "--ao-samples", "4"])
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
    // Without backups: the CPU device could otherwise deliver the GPU's tasks before its
    // launch starts, and a launch never started cannot fail.
    let (gpu, gpu_png) = run(
        "cpu:1,gpu:all",
        &["--fail", "1@1", "--no-backups"],
        "fail.png",
    );
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
    let first = &v["failures"][0];
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

/// `--walk reduced` and `--walk first-leaf` (the thesis's walks of the sampled paths' camera
/// rays) and `--walk trace` (the sampled paths rendered) plan with their estimate and say so;
/// the image is the same.
#[test]
fn every_walk_renders_the_same_image() {
    for shader in ["whitted", "ao"] {
        let (want, _) = render_with(
            "walk-ref",
            shader,
            &["--devices", "cpu:1", "--mode", "regular"],
        );
        for walk in ["trace", "reduced", "first-leaf"] {
            let args = ["--devices", "cpu:2", "--policy", "hybrid", "--walk", walk];
            let (png, v) = render_with(&format!("walk-{shader}-{walk}"), shader, &args);
            assert!(png == want, "{shader} {walk}: the image differs");
            assert_eq!(v["walk"], walk);
            assert_eq!(v["estimated"], true, "{v}");
        }
    }
}
