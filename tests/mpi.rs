use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::testkit::{cobalt, temp_dir};

/// The longest a test's `mpirun` may take: a hang fails the test instead of the CI job.
const DEADLINE: Duration = Duration::from_secs(120);

/// `mpirun` with the flags CI needs (root in a container; more ranks than cores), the given
/// launcher arguments, then `args`; killed at the deadline.
fn mpirun(launch: &[&str], dir: &Path) -> Output {
    let mut child = Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe"])
        .args(launch)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mpirun runs (Debian: openmpi-bin)");
    let start = Instant::now();
    while child.try_wait().expect("waits on mpirun").is_none() {
        if start.elapsed() > DEADLINE {
            let _ = child.kill();
            panic!("mpirun {launch:?} still running after {DEADLINE:?}: a hang");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().expect("mpirun output")
}

const COBALT: &str = env!("CARGO_BIN_EXE_cobalt");

fn render_args<'a>(scene: &'a str, policy: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "render",
        "--scene",
        scene,
        "--shader",
        "ao",
        "--ao-samples",
        "4",
        "--size",
        "64x64",
        "--task-size",
        "512",
        "--devices",
        "cpu:1",
        "--policy",
        policy,
        "--out",
        out,
    ]
}

#[test]
fn three_ranks_render_the_image_of_one_process_byte_for_byte() {
    let dir = temp_dir("mpi-image");
    let single = dir.join("single.png");
    let out = cobalt(&render_args(
        "builtin:cornell",
        "static-lpt",
        single.to_str().expect("utf-8 path"),
    ));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let expected = std::fs::read(&single).expect("the single-process image");

    for policy in ["static-lpt", "queue-fifo", "hybrid"] {
        let name = format!("{policy}.png");
        let mut launch = vec!["-np", "3", COBALT];
        launch.extend(render_args("builtin:cornell", policy, &name));
        launch.extend(["--report", "report.json"]);
        // Backups let rank 0 deliver a slow rank's tasks first, so only a binding plan
        // shows for certain that ranks 1 and 2 render their share.
        if policy != "queue-fifo" {
            launch.push("--no-backups");
        }
        let run = mpirun(&launch, &dir);
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            run.status.success(),
            "{policy}: {stdout}\n{}",
            String::from_utf8_lossy(&run.stderr)
        );
        assert!(stdout.contains("on 3 rank(s)"), "{stdout}");
        let image = std::fs::read(dir.join(&name)).expect("rank 0 wrote the image");
        assert!(
            image == expected,
            "{policy}: the image over 3 ranks differs"
        );
        let report: serde_json::Value = serde_json::from_slice(
            &std::fs::read(dir.join("report.json")).expect("rank 0 wrote the report"),
        )
        .expect("the report is JSON");
        assert_eq!(report["ranks"], 3);
        check_path_report(policy, &report);
    }
}

/// Ranks are path devices beside rank 0's own: every task delivered once, and under a
/// binding plan ranks 1 and 2 rendered paths; only task ranges went out, never a ray.
fn check_path_report(policy: &str, report: &serde_json::Value) {
    let devices = report["devices"].as_array().expect("devices");
    let tasks = |name: &str| {
        devices
            .iter()
            .find(|d| d["name"] == name)
            .and_then(|d| d["tasks"].as_u64())
            .unwrap_or_else(|| panic!("{policy}: no device {name} in {report}"))
    };
    let all: u64 = devices.iter().filter_map(|d| d["tasks"].as_u64()).sum();
    assert_eq!(all, report["tasks"].as_u64().expect("tasks"), "{report}");
    if !policy.starts_with("queue") {
        assert!(tasks("rank1") + tasks("rank2") > 0, "{policy}: {report}");
    }
    let out = report["host_to_device_bytes"].as_u64().expect("bytes out");
    assert!(out <= 64 * all, "{policy}: {out} bytes for {all} tasks");
}

#[test]
fn a_scene_missing_on_every_rank_ends_every_rank_with_its_error() {
    let dir = temp_dir("mpi-missing");
    let mut launch = vec!["-np", "3", COBALT];
    launch.extend(render_args("no-such-scene.obj", "static-lpt", "never.png"));
    let run = mpirun(&launch, &dir);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    // mpirun ends the job when the first rank exits, so maybe only one rank gets to print;
    // whichever it is names every rank's failure.
    let why = "no-such-scene.obj: cannot read";
    let whole = format!("cobalt: error: loading the scene failed on rank 0: {why}");
    let line = stderr
        .lines()
        .find(|l| l.contains(&whole))
        .unwrap_or_else(|| panic!("no error naming every rank: {stderr}"));
    assert!(line.contains(&format!("; rank 1: {why}")), "{line}");
    assert!(line.contains(&format!("; rank 2: {why}")), "{line}");
    assert!(!dir.join("never.png").exists());
}

#[test]
fn a_scene_missing_on_one_rank_ends_every_rank() {
    // Two working directories: the scene (a relative path) is in the first only, where
    // rank 0 runs; ranks 1 and 2 run in the second.
    let dir = temp_dir("mpi-one-missing");
    let (here, there) = (dir.join("here"), dir.join("there"));
    std::fs::create_dir_all(&here).expect("dir");
    std::fs::create_dir_all(&there).expect("dir");
    std::fs::write(here.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").expect("scene");
    let args = render_args("tri.obj", "static-lpt", "never.png");
    let mut launch = vec!["-np", "1", "-wdir", here.to_str().expect("utf-8"), COBALT];
    launch.extend(&args);
    launch.extend([
        ":",
        "-np",
        "2",
        "-wdir",
        there.to_str().expect("utf-8"),
        COBALT,
    ]);
    launch.extend(&args);
    let run = mpirun(&launch, &dir);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    // Rank 0 loaded it, and still stops, saying where it failed.
    assert!(
        stderr.contains(
            "cobalt: error: loading the scene failed on rank 1: tri.obj: cannot read: No such file or directory (os error 2); rank 2: tri.obj: cannot read"
        ),
        "{stderr}"
    );
    assert!(!here.join("never.png").exists());
}

/// Two ranks: each policy's run, its balance and MPI time, and the simulated clusters
/// replaying a single-node render.
#[test]
fn bench_over_mpi_reports_balance_communication_and_simulated_clusters() {
    let dir = temp_dir("mpi-bench");
    let launch = [
        "-np",
        "2",
        COBALT,
        "bench",
        "--mpi",
        "--size",
        "32x32",
        "--shaders",
        "ao",
        "--ao-samples",
        "2",
        "--task-sizes",
        "256",
        "--devices",
        "cpu:1",
        "--json",
        "bench.json",
    ];
    let run = mpirun(&launch, &dir);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("Over MPI: 2 rank(s)"), "{stdout}");
    let records: Vec<serde_json::Value> = serde_json::from_slice(
        &std::fs::read(dir.join("bench.json")).expect("rank 0 wrote the records"),
    )
    .expect("JSON");
    let measured: Vec<_> = records.iter().filter(|r| r["source"] == "mpi").collect();
    let policies: Vec<_> = measured.iter().map(|r| r["policy"].clone()).collect();
    assert_eq!(
        policies,
        ["static-lpt", "queue-fifo", "queue-sorted", "hybrid"]
    );
    for r in &measured {
        let balance = r["balance_efficiency"].as_f64().expect("balance");
        assert!(balance > 0.0 && balance <= 1.0 + 1e-9, "{r}");
        assert!(r["comm_seconds"].as_f64().expect("comm") > 0.0, "{r}");
        assert!(r["mrays_per_s"].as_f64().expect("rate") > 0.0, "{r}");
    }
    // A static plan sends rank 1 its share, one batch per frame. A queue sends
    // a batch per task rank 1 takes: on a render this small, rank 0 (which starts first) may drain
    // the queue before rank 1 asks, so a queue may send none.
    let batches = |p: &str| {
        measured.iter().find(|r| r["policy"] == p).expect("run")["batches"]
            .as_u64()
            .expect("batches")
    };
    for p in ["static-lpt", "hybrid"] {
        assert!(batches(p) > 0, "{p}");
    }
    let simulated: Vec<_> = records
        .iter()
        .filter(|r| r["source"] == "simulated-cluster")
        .collect();
    // 2 node counts × 2 links × 4 policies, each at a measured, positive latency.
    assert_eq!(simulated.len(), 16);
    for r in &simulated {
        assert!(
            [16, 64].contains(&r["devices"].as_u64().expect("devices")),
            "{r}"
        );
        assert!(r["latency"].as_f64().expect("latency") > 0.0, "{r}");
    }
}

/// The single-process bench's options that `--mpi` does not offer are refused, naming them,
/// rather than ignored.
#[test]
fn bench_over_mpi_refuses_the_options_it_does_not_offer() {
    for extra in [["--repeats", "2"], ["--simulate", "8"]] {
        let o = cobalt(&[&["bench", "--mpi"][..], &extra[..]].concat());
        assert_eq!(o.status.code(), Some(2), "{extra:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(extra[0]), "{extra:?}: {err}");
    }
}
