use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use proptest::prelude::*;

use crate::testkit::{cobalt, temp_dir};

/// A directory of its own for each test (and each proptest case), so that "nothing else was
/// left here" can be checked by listing it.
fn fresh(tag: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = temp_dir("hostile").join(format!("{tag}-{}", N.fetch_add(1, Ordering::Relaxed)));
    std::fs::create_dir_all(&dir).expect("test dir");
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temp path")
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("list dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Exit status 2, no panic, and a message holding every one of `needles`.
pub(crate) fn refused(o: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in: {err}");
    }
    err
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn render(scene: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        "--scene",
        scene,
        "--size",
        "8x8",
        "--devices",
        "cpu:1",
    ];
    args.extend(extra);
    cobalt(&args)
}

/// Rays aimed at the Cornell box from outside it: `f32 × 8` each.
fn rays(n: usize) -> Vec<u8> {
    let mut out = Vec::new();
    for i in 0..n {
        let x = (i as f32 / n.max(1) as f32) - 0.5;
        for v in [x, 0.0, -5.0, 0.0, 0.0, 1.0, 0.0, f32::INFINITY] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

fn run_with_stdin(args: &[&str], input: &[u8], env: &[(&str, &str)]) -> Output {
    let mut cmd = crate::testkit::command();
    cmd.args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().expect("cobalt runs");
    let mut stdin = child.stdin.take().expect("stdin");
    // The command may refuse before reading all of it.
    let _ = stdin.write_all(input);
    drop(stdin);
    child.wait_with_output().expect("cobalt ends")
}

#[test]
fn an_input_given_as_an_output_is_refused_and_kept() {
    let dir = fresh("input-as-output");
    let scene = dir.join("s.obj");
    std::fs::write(&scene, TRIANGLE).unwrap();
    refused(
        &render(s(&scene), &["--out", s(&scene)]),
        &["--out", "--scene"],
    );
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), TRIANGLE);

    let r = dir.join("r.bin");
    std::fs::write(&r, rays(4)).unwrap();
    let args = [
        "trace",
        "--scene",
        "builtin:cornell",
        "--rays",
        s(&r),
        "--out",
        s(&r),
    ];
    refused(&cobalt(&args), &["--out", "--rays"]);
    assert_eq!(std::fs::read(&r).unwrap(), rays(4));

    // The same file under another name (a hard link) is still the input.
    let other = dir.join("other.bin");
    std::fs::hard_link(&r, &other).unwrap();
    let args = [
        "trace",
        "--scene",
        "builtin:cornell",
        "--rays",
        s(&r),
        "--out",
        s(&other),
    ];
    refused(&cobalt(&args), &["--rays"]);
    assert_eq!(std::fs::read(&r).unwrap(), rays(4));
    assert_eq!(names(&dir), ["other.bin", "r.bin", "s.obj"]);
}

#[test]
fn no_output_of_any_command_replaces_any_of_its_inputs() {
    let dir = fresh("every-input");
    let scene = dir.join("v.obj");
    std::fs::write(&scene, TRIANGLE).unwrap();
    let calibration = dir.join("c.json");
    let empty = "{\"version\": 1, \"entries\": []}\n";
    std::fs::write(&calibration, empty).unwrap();
    let (v, c) = (s(&scene), s(&calibration));
    let bench = ["bench", "--scene", v, "--size", "8x8", "--devices", "cpu:1"];
    let bench = |extra: &[&str]| cobalt(&[&bench[..], extra, &["--no-trade"]].concat());
    // The same file under another name: a hard link, a symbolic link, a path through `..`.
    let hard = dir.join("hard.obj");
    std::fs::hard_link(&scene, &hard).unwrap();
    let soft = dir.join("soft.json");
    std::os::unix::fs::symlink(&calibration, &soft).unwrap();
    let dotted = format!(
        "{}/../{}/v.obj",
        s(&dir),
        dir.file_name().unwrap().to_str().unwrap()
    );
    let cases: Vec<(Output, [&str; 2])> = vec![
        (bench(&["--json", v]), ["--json", "--scene"]),
        (bench(&["--json", &dotted]), ["--json", "--scene"]),
        (
            bench(&["--calibration", c, "--json", c]),
            ["--json", "--calibration"],
        ),
        (bench(&["--calibration", v]), ["--calibration", "--scene"]),
        (
            render(v, &["--calibration", c, "--report", c]),
            ["--report", "--calibration"],
        ),
        (
            render(v, &["--calibration", s(&soft), "--out", c]),
            ["--out", "--calibration"],
        ),
        (
            render(v, &["--calibration", s(&hard)]),
            ["--calibration", "--scene"],
        ),
        (render(s(&hard), &["--report", v]), ["--report", "--scene"]),
    ];
    // `--plots DIR` writes `cost.png` there: one that is the calibration is refused.
    std::fs::hard_link(&calibration, dir.join("cost.png")).unwrap();
    let plots = bench(&["--plots", s(&dir), "--calibration", c]);
    for (o, flags) in cases
        .iter()
        .chain([(plots, ["--plots", "--calibration"])].iter())
    {
        refused(o, &flags[..]);
        assert!(o.stdout.is_empty(), "refused before any work");
    }
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), TRIANGLE);
    assert_eq!(std::fs::read_to_string(&calibration).unwrap(), empty);
    assert_eq!(
        names(&dir),
        ["c.json", "cost.png", "hard.obj", "soft.json", "v.obj"]
    );
}

#[cfg(unix)]
#[test]
fn a_read_only_output_is_refused_before_the_work_and_kept() {
    use std::os::unix::fs::PermissionsExt;
    let dir = fresh("read-only");
    let out = dir.join("ro.png");
    std::fs::write(&out, "keep").unwrap();
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o444)).unwrap();
    let report = dir.join("r.json");
    let o = render(
        "builtin:cornell",
        &["--report", s(&report), "--out", s(&out)],
    );
    refused(&o, &["--out", "read-only"]);
    assert!(o.stdout.is_empty(), "refused before any work");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "keep");
    assert_eq!(names(&dir), ["ro.png"]);
    let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o444);

    // A user who may write the directory but not the file (another's 0644 file): as root,
    // the command runs as `nobody` through `setpriv`, where there is one.
    let shared = fresh("not-theirs");
    std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o777)).unwrap();
    let theirs = shared.join("theirs.png");
    std::fs::write(&theirs, "keep").unwrap();
    std::fs::set_permissions(&theirs, std::fs::Permissions::from_mode(0o644)).unwrap();
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout == b"0\n");
    let mut cmd = Command::new("setpriv");
    cmd.args(["--reuid=65534", "--regid=65534", "--clear-groups"])
        .arg(env!("CARGO_BIN_EXE_cobalt"))
        .args([
            "render",
            "--scene",
            "builtin:cornell",
            "--size",
            "8x8",
            "--no-calibration",
        ])
        .args(["--devices", "cpu:1", "--out", s(&theirs)]);
    match cmd.output() {
        // Where `nobody` cannot run the binary, setpriv says so and there is nothing to check.
        Ok(o) if root && !String::from_utf8_lossy(&o.stderr).contains("setpriv:") => {
            refused(&o, &["--out", "cannot be written by this user"]);
        }
        _ => eprintln!("not root or no setpriv: the other user's file is not checked"),
    }
    assert_eq!(std::fs::read_to_string(&theirs).unwrap(), "keep");
    assert_eq!(names(&shared), ["theirs.png"]);
}

#[cfg(unix)]
#[test]
fn outputs_that_are_not_regular_files_are_refused() {
    let dir = fresh("special");
    let victim = dir.join("victim.png");
    std::fs::write(&victim, "keep").unwrap();
    let link = dir.join("link.png");
    std::os::unix::fs::symlink(&victim, &link).unwrap();
    let fifo = dir.join("fifo");
    let made = Command::new("mkfifo").arg(&fifo).status();
    let sub = dir.join("sub");
    std::fs::create_dir(&sub).unwrap();
    let mut cases = vec![
        (link.clone(), "symbolic link"),
        (sub.clone(), "directory"),
        (PathBuf::from("/dev/null"), "device"),
        (dir.join("sub/"), "directory"),
        (dir.join("missing/x.png"), "does not exist"),
        (victim.join("x.png"), "not a directory"),
    ];
    if made.is_ok_and(|s| s.success()) {
        cases.push((fifo.clone(), "FIFO"));
    }
    for (path, why) in cases {
        let o = render("builtin:cornell", &["--out", s(&path)]);
        refused(&o, &["--out", why]);
    }
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    // The report and the cost image are checked the same way.
    for flag in ["--report", "--cost-image"] {
        let out = dir.join("ok.png");
        refused(
            &render("builtin:cornell", &["--out", s(&out), flag, "/dev/null"]),
            &[flag],
        );
        assert!(!out.exists());
    }
}

#[test]
fn a_bad_output_fails_before_the_work_and_keeps_the_old_outputs() {
    let dir = fresh("late");
    let out = dir.join("out.png");
    std::fs::write(&out, "old image").unwrap();
    let report = dir.join("no-such-dir/r.json");
    let o = render(
        "builtin:cornell",
        &["--out", s(&out), "--report", s(&report)],
    );
    refused(&o, &["--report", "does not exist"]);
    assert!(o.stdout.is_empty(), "nothing rendered");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old image");
    assert_eq!(names(&dir), ["out.png"]);

    // Two outputs at one path.
    let o = render("builtin:cornell", &["--out", s(&out), "--report", s(&out)]);
    refused(&o, &["--report", "--out"]);
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old image");
}

#[test]
fn a_failure_after_the_checks_leaves_old_outputs_and_no_temporaries() {
    let dir = fresh("fail-mid");
    let out = dir.join("hits.bin");
    std::fs::write(&out, "old hits").unwrap();
    let bad = dir.join("bad.bin");
    let mut bytes = rays(3);
    bytes.truncate(70);
    std::fs::write(&bad, &bytes).unwrap();
    let args = [
        "trace",
        "--scene",
        "builtin:cornell",
        "--rays",
        s(&bad),
        "--out",
        s(&out),
    ];
    refused(&cobalt(&args), &["bad.bin", "truncated"]);
    let scene = dir.join("broken.obj");
    std::fs::write(&scene, "v 0 0 0\nf 1 2 3\n").unwrap();
    let o = render(
        s(&scene),
        &["--out", s(&out), "--report", s(&dir.join("r.json"))],
    );
    refused(&o, &["broken.obj"]);
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old hits");
    assert_eq!(names(&dir), ["bad.bin", "broken.obj", "hits.bin"]);
}

#[cfg(unix)]
#[test]
fn writes_replace_atomically_keep_permissions_and_ignore_planted_links() {
    use std::os::unix::fs::PermissionsExt;
    let dir = fresh("atomic");
    let out = dir.join("out.png");
    std::fs::write(&out, "old").unwrap();
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o640)).unwrap();
    // A link at the name the old writer used for its temporary must not be followed.
    let victim = dir.join("victim");
    std::fs::write(&victim, "keep").unwrap();
    std::os::unix::fs::symlink(&victim, dir.join("out.png.partial")).unwrap();
    let report = dir.join("r.json");
    ok(&render(
        "builtin:cornell",
        &["--out", s(&out), "--report", s(&report)],
    ));
    assert!(std::fs::read(&out).unwrap().starts_with(b"\x89PNG"));
    let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o640);
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
    assert!(serde_json::from_slice::<serde_json::Value>(&std::fs::read(&report).unwrap()).is_ok());
    assert_eq!(
        names(&dir),
        ["out.png", "out.png.partial", "r.json", "victim"]
    );
}

#[test]
fn dash_is_standard_input_and_output() {
    let n = 5;
    let o = run_with_stdin(
        &[
            "trace",
            "--scene",
            "builtin:cornell",
            "--rays",
            "-",
            "--out",
            "-",
            "--json",
        ],
        &rays(n),
        &[],
    );
    ok(&o);
    assert_eq!(o.stdout.len(), 8 * n, "the hits alone on standard output");
    let report: serde_json::Value = serde_json::from_slice(&o.stderr).expect("JSON on stderr");
    assert_eq!(report["rays"], n);

    let o = run_with_stdin(&["schedule", "--costs", "-", "--json"], b"1\n2\n3\n", &[]);
    ok(&o);
    let o = run_with_stdin(&["schedule", "--costs", "-", "--actual", "-"], b"1\n", &[]);
    refused(&o, &["--actual", "standard input"]);
    let dir = fresh("dash");
    let o = run_with_stdin(
        &[
            "render",
            "--scene",
            "-",
            "--size",
            "8x8",
            "--devices",
            "cpu:1",
            "--out",
            s(&dir.join("a.png")),
        ],
        TRIANGLE.as_bytes(),
        &[],
    );
    ok(&o);
    let o = render("builtin:cornell", &["--out", "-", "--report", "-"]);
    refused(&o, &["--report", "standard output"]);
}

#[test]
fn absurd_sizes_are_refused_before_allocating() {
    for (args, flag) in [
        (vec!["knn", "--points", "18446744073709551615"], "--points"),
        (vec!["knn", "--points", "1000000000000"], "--points"),
        (vec!["knn", "--queries", "100000000000"], "--queries"),
        (vec!["knn", "--k", "100000000"], "--k"),
        (vec!["knn", "--devices", "1000000"], "--devices"),
        (
            vec!["collide", "--bodies", "18446744073709551615"],
            "--bodies",
        ),
        (vec!["collide", "--bodies", "1000000000"], "--bodies"),
        (vec!["collide", "--terrain", "4294967296"], "--terrain"),
        (vec!["collide", "--terrain", "100000"], "--terrain"),
        (vec!["collide", "--devices", "1000000"], "--devices"),
        (
            vec![
                "render",
                "--scene",
                "builtin:cornell",
                "--devices",
                "cpu:1024/1024",
            ],
            "--devices",
        ),
        (
            vec![
                "render",
                "--scene",
                "builtin:cornell",
                "--devices",
                "cpu:8/1024",
            ],
            "--devices",
        ),
    ] {
        let o = cobalt(&args);
        refused(&o, &[flag]);
    }
}

#[test]
fn a_byte_order_mark_is_read_and_utf16_is_named() {
    let dir = fresh("bom");
    let plain = dir.join("plain.obj");
    std::fs::write(&plain, TRIANGLE).unwrap();
    let bom = dir.join("bom.obj");
    std::fs::write(
        &bom,
        [b"\xEF\xBB\xBF".as_slice(), TRIANGLE.as_bytes()].concat(),
    )
    .unwrap();
    let r = dir.join("r.bin");
    let mut ray = Vec::new();
    for v in [0.2f32, 0.2, -1.0, 0.0, 0.0, 1.0, 0.0, f32::INFINITY] {
        ray.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&r, &ray).unwrap();
    let mut hits = Vec::new();
    for (scene, out) in [(&plain, "a.bin"), (&bom, "b.bin")] {
        let out = dir.join(out);
        ok(&cobalt(&[
            "trace",
            "--scene",
            s(scene),
            "--rays",
            s(&r),
            "--out",
            s(&out),
        ]));
        hits.push(std::fs::read(out).unwrap());
    }
    assert_eq!(hits[0], hits[1]);
    assert_eq!(&hits[0][4..], &0u32.to_le_bytes(), "the triangle is hit");

    let utf16 = dir.join("utf16.obj");
    let mut body = vec![0xFF, 0xFE];
    for u in TRIANGLE.encode_utf16() {
        body.extend_from_slice(&u.to_le_bytes());
    }
    std::fs::write(&utf16, body).unwrap();
    refused(
        &render(s(&utf16), &["--out", s(&dir.join("x.png"))]),
        &["utf16.obj", "UTF-8"],
    );
    assert!(!dir.join("x.png").exists());
}

/// A polygon of 10⁵ vertices fans into as many overlapping slivers, on which PLOC's wider
/// searches take time growing with n²; the builder searches only nearest neighbours there
/// (about 3 s on the two-core VM), and the bound leaves room for a loaded machine.
#[test]
fn a_polygon_of_a_hundred_thousand_vertices_renders_in_seconds() {
    let dir = fresh("polygon");
    let n = 100_000;
    let mut obj = String::new();
    for k in 0..n {
        let a = k as f64 / n as f64 * std::f64::consts::TAU;
        obj += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    obj += "f";
    for k in 1..=n {
        obj += &format!(" {k}");
    }
    obj += "\n";
    let scene = dir.join("poly.obj");
    std::fs::write(&scene, obj).unwrap();
    let start = std::time::Instant::now();
    ok(&render(s(&scene), &["--out", s(&dir.join("p.png"))]));
    let took = start.elapsed();
    assert!(took.as_secs() < 20, "{took:?}");
}

#[test]
fn a_face_or_line_past_its_limit_is_refused_with_the_file_and_line() {
    let dir = fresh("huge-face");
    let scene = dir.join("face.obj");
    let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf");
    obj += &" 1".repeat((1 << 20) + 1);
    obj += "\n";
    std::fs::write(&scene, &obj).unwrap();
    refused(
        &render(s(&scene), &["--out", s(&dir.join("p.png"))]),
        &["face.obj:4", "more than 1048576 vertices"],
    );
    let line = dir.join("line.obj");
    std::fs::write(&line, format!("v 0 0 0\n#{}\n", "x".repeat(32 << 20))).unwrap();
    refused(
        &render(s(&line), &["--out", s(&dir.join("p.png"))]),
        &["line.obj:2", "bytes long"],
    );
    assert_eq!(names(&dir), ["face.obj", "line.obj"]);
}

#[test]
fn overflowing_costs_are_an_error_naming_the_value() {
    let dir = fresh("overflow");
    let costs = dir.join("c.txt");
    std::fs::write(&costs, "1e308\n1e308\n").unwrap();
    let o = cobalt(&["schedule", "--costs", s(&costs)]);
    let err = refused(&o, &["c.txt", "1e308", "overflow"]);
    assert!(o.stdout.is_empty(), "{err}");
    // Finite costs that a slow device turns into an infinite makespan.
    std::fs::write(&costs, "1e307\n").unwrap();
    let o = cobalt(&["schedule", "--costs", s(&costs), "--speeds", "1e-10"]);
    refused(&o, &["--speeds", "overflow"]);
    assert!(!String::from_utf8_lossy(&o.stdout).contains("NaN"));
}

#[test]
fn every_device_failing_is_exit_3_unless_a_host_fallback_is_allowed() {
    let dir = fresh("fallback");
    let out = dir.join("f.png");
    let report = dir.join("f.json");
    let args = ["--fail", "0@0", "--out", s(&out), "--report", s(&report)];
    let o = render("builtin:cornell", &args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    for needle in [
        "--devices cpu:1",
        "device 0 (cpu0) failed",
        "--host-fallback",
    ] {
        assert!(err.contains(needle), "{needle:?} not in {err}");
    }
    assert!(names(&dir).is_empty(), "{:?}", names(&dir));

    let mut allowed = args.to_vec();
    allowed.push("--host-fallback");
    let o = render("builtin:cornell", &allowed);
    ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("on the host instead"), "{text}");
    assert_eq!(names(&dir), ["f.json", "f.png"]);
    let json = std::fs::read_to_string(&report).unwrap();
    assert!(json.contains("\"host_fallback\": true"), "{json}");
}

#[test]
fn errors_blame_the_right_flag_and_list_the_valid_values() {
    let o = cobalt(&["tradeoff", "--reference", "0"]);
    let err = refused(&o, &["--reference"]);
    assert!(!err.contains("--ao-samples"), "{err}");
    refused(
        &cobalt(&["tradeoff", "--presets", "fast,bogus"]),
        &["--presets", "'bogus'", "very-slow"],
    );
    refused(
        &cobalt(&["tradeoff", "--ao-samples", "4,x,8"]),
        &["--ao-samples", "'x'"],
    );
    refused(
        &cobalt(&[
            "render",
            "--scene",
            "builtin:cornell",
            "--devices",
            "cpu:1,tpu:2",
        ]),
        &["--devices", "tpu:2", "gpu:all"],
    );
}

#[cfg(feature = "gpu")]
#[test]
fn a_bad_wgpu_backend_is_named_as_the_cause() {
    let dir = fresh("backend");
    let r = dir.join("r.bin");
    std::fs::write(&r, rays(2)).unwrap();
    let out = dir.join("h.bin");
    let o = run_with_stdin(
        &[
            "trace",
            "--scene",
            "builtin:cornell",
            "--rays",
            s(&r),
            "--out",
            s(&out),
            "--device",
            "gpu",
        ],
        b"",
        &[("WGPU_BACKEND", "vulcan")],
    );
    let err = refused(&o, &["WGPU_BACKEND", "vulcan", "vulkan, metal, dx12"]);
    assert!(!err.contains("install"), "{err}");
    let o = run_with_stdin(
        &[
            "render",
            "--scene",
            "builtin:cornell",
            "--size",
            "8x8",
            "--devices",
            "gpu:0",
            "--out",
            s(&out),
        ],
        b"",
        &[("WGPU_BACKEND", "opengl")],
    );
    refused(&o, &["WGPU_BACKEND"]);
    assert_eq!(names(&dir), ["r.bin"]);
}

/// Flags and values, good and bad, that random argument lists are drawn from. Sizes stay small
/// so that the lists that happen to be valid finish quickly.
const WORDS: &[&str] = &[
    "--out",
    "--report",
    "--cost-image",
    "--size",
    "8x8",
    "0x1",
    "--devices",
    "cpu:1",
    "cpu:0",
    "gpu:7",
    "cpu:1024/1024",
    "--ao-samples",
    "2",
    "-1",
    "--shader",
    "ao",
    "--policy",
    "hybrid",
    "--task-size",
    "0",
    "99999999999999999999",
    "--camera",
    "3",
    "--fail",
    "0@1",
    "--mode",
    "regular",
    "-",
    "/dev/null",
    ".",
    "..",
    "",
    "nan",
    "inf",
    "--json",
    "--preset",
    "fastest",
    "--sample-rate",
    "1e-300",
    "--eye",
    "1,2,3",
    "--at",
    "1,2,3",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// `render` with random arguments: an exit status of 0 or 2, never a panic, and on failure
    /// nothing written to the working directory.
    #[test]
    fn random_render_arguments_never_panic_or_leave_files(
        picks in proptest::collection::vec(0..WORDS.len(), 0..8)
    ) {
        let dir = fresh("args");
        let mut args = vec!["render", "--scene", "builtin:cornell", "--size", "8x8"];
        args.extend(picks.iter().map(|&i| WORDS[i]));
        let o = crate::testkit::command()
            .args(&args)
            .current_dir(&dir)
            .stdin(Stdio::null())
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&o.stderr);
        prop_assert!(!err.contains("panicked"), "{args:?}: {err}");
        prop_assert!(matches!(o.status.code(), Some(0 | 2)), "{args:?}: {err}");
        if !o.status.success() {
            prop_assert!(names(&dir).is_empty(), "{args:?} left {:?}", names(&dir));
        }
    }

    /// Mutated ray files: hits or an error naming the file, and no output on failure.
    #[test]
    fn mutated_ray_files_never_panic(
        edits in proptest::collection::vec((0usize..160, any::<u8>(), any::<bool>()), 0..6)
    ) {
        let dir = fresh("rays");
        let mut bytes = rays(5);
        for (at, byte, insert) in edits {
            let at = at % (bytes.len() + 1);
            if insert || at == bytes.len() {
                bytes.insert(at, byte);
            } else {
                bytes[at] = byte;
            }
        }
        let r = dir.join("r.bin");
        std::fs::write(&r, &bytes).unwrap();
        let out = dir.join("h.bin");
        let o = cobalt(&["trace", "--scene", "builtin:cornell", "--rays", s(&r), "--out", s(&out)]);
        let err = String::from_utf8_lossy(&o.stderr);
        prop_assert!(!err.contains("panicked"), "{err}");
        if o.status.success() {
            prop_assert_eq!(std::fs::read(&out).unwrap().len(), bytes.len() / 32 * 8);
        } else {
            prop_assert_eq!(o.status.code(), Some(2));
            prop_assert!(err.contains("r.bin"), "{}", err);
            prop_assert_eq!(names(&dir), vec!["r.bin".to_string()]);
        }
    }

    /// Random cost files: a plan or an error naming the file, never inf or NaN.
    #[test]
    fn random_cost_files_never_panic_or_print_nan(
        lines in proptest::collection::vec(
            prop_oneof![
                any::<f64>().prop_map(|c| c.to_string()),
                (0u32..1000).prop_map(|c| c.to_string()),
                Just("1e308".to_string()),
                Just("-0".to_string()),
                Just("# note".to_string()),
                "[ -~]{0,6}",
            ],
            0..12,
        )
    ) {
        let dir = fresh("costs");
        let costs = dir.join("c.txt");
        std::fs::write(&costs, lines.join("\n")).unwrap();
        let o = cobalt(&["schedule", "--costs", s(&costs), "--speeds", "1,0.5", "--json"]);
        let err = String::from_utf8_lossy(&o.stderr);
        let out = String::from_utf8_lossy(&o.stdout);
        prop_assert!(!err.contains("panicked"), "{err}");
        if o.status.success() {
            prop_assert!(!out.contains("NaN") && !out.contains("inf"), "{out}");
        } else {
            prop_assert_eq!(o.status.code(), Some(2));
            prop_assert!(err.contains("c.txt") || err.contains("--"), "{}", err);
        }
    }
}

#[test]
fn a_missing_home_is_not_created_and_the_run_says_it_does_not_learn() {
    let dir = fresh("no-home");
    let home = dir.join("missing/home");
    let out = dir.join("o.png");
    let o = crate::testkit::command()
        .env_remove("XDG_CACHE_HOME")
        .env("HOME", &home)
        .args(["render", "--scene", "builtin:cornell", "--size", "8x8"])
        .args(["--devices", "cpu:2", "--out", s(&out)])
        .output()
        .expect("cobalt runs");
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.matches("does not learn").count(), 1, "{err}");
    assert!(err.contains(s(&home)), "{err}");
    assert_eq!(names(&dir), ["o.png"], "HOME was not made");
}

/// Under an address-space cap (`ulimit -v`), sizes past what the process may allocate are
/// refused by the memory check, naming the flag, instead of panicking or aborting inside an
/// allocation: scenes, images, AO's probes, kNN's points and queries, collision bodies.
#[cfg(unix)]
#[test]
fn limits_hold_under_a_memory_cap() {
    let dir = fresh("ulimit");
    let out = dir.join("x.png");
    let render = [
        "render",
        "--devices",
        "cpu:1",
        "--no-calibration",
        "--out",
        s(&out),
    ];
    let cornell = [&render[..], &["--scene", "builtin:cornell"]].concat();
    let ao = [&cornell[..], &["--shader", "ao", "--size", "2048x2048"]].concat();
    let bench = [
        "bench",
        "--scene",
        "builtin:cornell",
        "--shaders",
        "ao",
        "--policies",
        "lpt",
    ];
    for (args, flag) in [
        (
            [&render[..], &["--scene", "builtin:forest:64"]].concat(),
            "--scene",
        ),
        (
            [&render[..], &["--scene", "builtin:hairball:64"]].concat(),
            "--scene",
        ),
        ([&cornell[..], &["--size", "8192x8192"]].concat(), "--size"),
        (
            [&ao[..], &["--ao-samples", "4096"]].concat(),
            "--ao-samples",
        ),
        (
            [&bench[..], &["--ao-samples", "4096", "--size", "2048x2048"]].concat(),
            "--ao-samples",
        ),
        (
            [
                "tradeoff",
                "--scene",
                "builtin:cornell",
                "--size",
                "2048x2048",
            ]
            .to_vec(),
            "--reference",
        ),
        (["knn", "--points", "100000000"].to_vec(), "--points"),
        (
            ["knn", "--queries", "30000000", "--k", "64"].to_vec(),
            "--queries",
        ),
        (["collide", "--bodies", "10000000"].to_vec(), "--bodies"),
    ] {
        let o = Command::new("sh")
            .arg("-c")
            .arg("ulimit -v 4000000 && exec \"$0\" \"$@\"")
            .arg(env!("CARGO_BIN_EXE_cobalt"))
            .args(&args)
            .output()
            .expect("sh runs");
        refused(&o, &[flag, "of memory"]);
    }
    assert_eq!(names(&dir), Vec::<String>::new());
}

/// A GPU run that succeeds prints nothing alarming, even without a desktop session
/// (`XDG_RUNTIME_DIR` unset): no `error:` line from the graphics stack. Without any adapter:
/// a note, or a failure when `CI` is set.
#[test]
fn a_successful_gpu_run_prints_no_error_line() {
    let dir = fresh("quiet-gpu");
    let out = dir.join("q.png");
    let o = crate::testkit::command()
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("NODEVICE_SELECT")
        .env("COBALT_GPU_SOFTWARE", "1")
        .args([
            "render",
            "--scene",
            "builtin:cornell:0.3",
            "--size",
            "16x16",
        ])
        .args(["--devices", "gpu:0", "--out", s(&out)])
        .output()
        .expect("the cobalt binary runs");
    let err = String::from_utf8_lossy(&o.stderr);
    if !o.status.success() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but the GPU run failed: {err}"
        );
        eprintln!("note: no GPU adapter, skipped: {err}");
        return;
    }
    assert!(!err.contains("error"), "{err}");
}

/// An entry listed twice in a list flag is refused with both entries, before anything runs:
/// a second policy or task size would repeat a run, two slowdowns or failure points of one
/// device contradict each other, and an adapter listed twice would be opened twice. Two CPU
/// entries are two groups of devices, and stay allowed.
#[test]
fn list_flags_refuse_an_entry_given_twice() {
    let dir = fresh("twice");
    let costs = dir.join("c.txt");
    std::fs::write(&costs, "1\n2\n").unwrap();
    let (png, cornell) = (dir.join("x.png"), ["--scene", "builtin:cornell"]);
    let render = |flag, list| vec!["render", "--size", "8x8", "--out", s(&png), flag, list];
    let cases: [(Vec<&str>, &[&str]); 9] = [
        (
            render("--devices", "gpu:0,gpu:0"),
            &["gpu:0 and gpu:0", "same adapter"],
        ),
        (render("--devices", "gpu:all,gpu:1"), &["gpu:all and gpu:1"]),
        (
            render("--slow", "0=2,0=3"),
            &["--slow", "0=2,0=3", "device 0 is listed twice"],
        ),
        (
            vec!["bench", "--policies", "lpt,static-lpt"],
            &["static-lpt is listed twice"],
        ),
        (vec!["bench", "--shaders", "ao,ao"], &["--shaders", "ao,ao"]),
        (
            vec!["bench", "--task-sizes", "512,64,512"],
            &["--task-sizes", "512,512"],
        ),
        (
            vec!["tradeoff", "--presets", "fast,medium,fast"],
            &["--presets", "fast,fast"],
        ),
        (
            vec!["tradeoff", "--ao-samples", "4,4"],
            &["--ao-samples", "4,4"],
        ),
        (
            vec!["schedule", "--costs", s(&costs), "--fail", "0@1,0@2"],
            &["--fail", "0@1,0@2", "device 0 is listed twice"],
        ),
    ];
    for (mut args, needles) in cases {
        if args[0] != "schedule" {
            args.extend(cornell);
        }
        refused(&cobalt(&args), needles);
    }
    assert_eq!(names(&dir), ["c.txt"]);
    let two = render("--devices", "cpu:1,cpu:1");
    ok(&cobalt(&[&two[..], &cornell].concat()));
}

/// Costs at the ends of `f64`: a makespan near `f64::MAX` keeps an honest balance (half, for
/// one busy device of two) rather than one that overflowed to 0, and subnormal costs plan.
#[test]
fn costs_at_the_ends_of_f64_give_honest_figures() {
    for (costs, balance) in [("1e308\n0\n", 0.5), ("1e-320\n1e-320\n", 1.0)] {
        let o = run_with_stdin(
            &["schedule", "--costs", "-", "--speeds", "1,1", "--json"],
            costs.as_bytes(),
            &[],
        );
        ok(&o);
        let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
        assert_eq!(report["balance_efficiency"], balance, "{costs:?}: {report}");
    }
}

/// A ray whose direction is too short for its reciprocal (1e-45) would report a hit at a NaN
/// distance: it is refused, naming the ray.
#[test]
fn a_ray_too_short_to_divide_by_is_refused() {
    let dir = fresh("short-ray");
    let mut ray = [0f32, 0.0, -5.0, 0.0, 0.0, 1e-45, 0.0, f32::INFINITY]
        .map(f32::to_le_bytes)
        .concat();
    let (rays, hits) = (dir.join("r.bin"), dir.join("h.bin"));
    let trace = |ray: &[u8]| {
        std::fs::write(&rays, ray).unwrap();
        let io = ["--rays", s(&rays), "--out", s(&hits)];
        cobalt(&[&["trace", "--scene", "builtin:cornell"][..], &io].concat())
    };
    refused(&trace(&ray), &["r.bin", "ray 0", "too small"]);
    ray[20..24].copy_from_slice(&1f32.to_le_bytes());
    ok(&trace(&ray));
}

/// The default camera of a flat scene (one triangle in `z = 0`, a floor in `y = 0`) stands
/// off its plane: it sees the scene, not its edge.
#[test]
fn the_default_camera_sees_a_flat_scene_from_off_its_plane() {
    let dir = fresh("flat");
    let png = dir.join("f.png");
    let floor = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3 4\n";
    for (name, obj) in [("one.obj", TRIANGLE), ("floor.obj", floor)] {
        let scene = dir.join(name);
        std::fs::write(&scene, obj).unwrap();
        let args = [
            "--shader",
            "ao",
            "--ao-samples",
            "1",
            "--json",
            "--out",
            s(&png),
        ];
        let o = render(s(&scene), &args);
        ok(&o);
        let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
        // Every primary ray that hits casts one probe: a scene seen edge-on casts none.
        let probes = report["total_rays"].as_u64().unwrap() - 64;
        assert!(probes > 16, "{name}: {report}");
    }
}

/// A scene whose every triangle has zero area (collinear corners, a point) has nothing to
/// trace: rendering, tracing or estimating it is refused naming the file, not a background
/// image with exit 0.
#[test]
fn a_scene_of_degenerate_triangles_only_is_refused() {
    let dir = fresh("degenerate");
    let scene = dir.join("line.obj");
    std::fs::write(&scene, "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\nf 1 1 1\n").expect("scene");
    let out = dir.join("line.png");
    let o = render(s(&scene), &["--out", s(&out)]);
    refused(&o, &["line.obj", "zero area"]);
    assert!(!out.exists());
    let ray_file = dir.join("rays.bin");
    std::fs::write(&ray_file, rays(1)).expect("rays");
    let hits = dir.join("hits.bin");
    let o = cobalt(&[
        "trace",
        "--scene",
        s(&scene),
        "--rays",
        s(&ray_file),
        "--out",
        s(&hits),
    ]);
    refused(&o, &["line.obj", "zero area"]);
    assert!(!hits.exists());
}
