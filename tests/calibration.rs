use std::path::Path;

use serde_json::Value;

use crate::testkit::{command, temp_dir};

/// `cobalt render` of a small AO image on two device classes, with `extra` flags, from a
/// cache directory of `cache`: the image and the JSON report, or the failed run's output.
fn render(dir: &Path, name: &str, cache: &Path, extra: &[&str]) -> std::process::Output {
    let out = dir.join(format!("{name}.png"));
    command()
        .env("XDG_CACHE_HOME", cache)
        .args(["render", "--scene", "builtin:cornell", "--shader", "ao"])
        .args(["--ao-samples", "4", "--size", "48x32", "--task-size", "96"])
        .args(["--devices", "cpu:2,cpu:1/2", "--json", "--out"])
        .arg(&out)
        .args(extra)
        .output()
        .expect("cobalt runs")
}

fn report(o: &std::process::Output) -> Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("a JSON report")
}

/// Two renders with one `--calibration` file: the first writes an entry per device class and
/// what its frames measured of running on both, the second plans its first frame with them,
/// and the image does not change (where a task runs never changes what its paths render).
/// The user's cache is left alone.
#[test]
fn a_second_render_plans_with_what_the_first_learnt() {
    let dir = temp_dir("calibration");
    let file = dir.join("learnt.json");
    let cache = dir.join("cache");
    let _ = std::fs::remove_file(&file);
    let _ = std::fs::remove_dir_all(&cache);
    let flag = ["--calibration", file.to_str().expect("a UTF-8 temp path")];

    // Three frames: every device at equal speeds (which measures them), the fastest class
    // alone, then every device as planned, the figure the choice keeps.
    let first = report(&render(
        &dir,
        "first",
        &cache,
        &[&flag[..], &["--repeats", "3"]].concat(),
    ));
    let c = &first["calibration"];
    assert_eq!(c["file"].as_str(), file.to_str(), "{c}");
    assert_eq!(c["loaded_entries"], 0, "{c}");
    assert_eq!(
        c["written_entries"], 3,
        "one entry per device class and the frame's choice of devices: {c}"
    );
    let stored: Value = serde_json::from_slice(&std::fs::read(&file).expect("the file"))
        .expect("the calibration is JSON");
    assert_eq!(stored["version"], 1);
    let devices: Vec<&str> = stored["entries"]
        .as_array()
        .expect("entries")
        .iter()
        .map(|e| e["device"].as_str().expect("a device"))
        .collect();
    assert_eq!(devices, ["cpu/1", "cpu/2"]);
    let choices = stored["choices"].as_array().expect("choices");
    assert_eq!(choices.len(), 1, "{stored}");
    assert_eq!(choices[0]["devices"], "cpu/1 + cpu/2");
    assert_eq!(choices[0]["mode"], "cost");
    assert!(
        choices[0]["all_seconds_per_path"]
            .as_f64()
            .is_some_and(|s| s > 0.0)
    );

    let second = report(&render(&dir, "second", &cache, &flag));
    assert_eq!(second["calibration"]["loaded_entries"], 2, "{second}");
    assert_eq!(
        std::fs::read(dir.join("first.png")).expect("the first image"),
        std::fs::read(dir.join("second.png")).expect("the second image"),
    );
    assert!(!cache.exists(), "the default cache was not touched");

    // Without a calibration, nothing is read or written.
    let before = std::fs::read(&file).expect("the file");
    let none = report(&render(&dir, "none", &cache, &["--no-calibration"]));
    assert_eq!(none["calibration"]["file"], Value::Null, "{none}");
    assert_eq!(none["calibration"]["loaded_entries"], 0);
    assert_eq!(std::fs::read(&file).expect("the file"), before);
    assert!(!cache.exists());
}

/// The default file is a cache: written where `XDG_CACHE_HOME` says, and when it is damaged,
/// a warning naming it and a fresh start. A damaged file the user named fails the command
/// before any work, naming the file and the line.
#[test]
fn a_damaged_calibration_is_named_and_only_the_cache_is_replaced() {
    let dir = temp_dir("calibration-damaged");
    let cache = dir.join("cache");
    let _ = std::fs::remove_dir_all(&cache);
    let default = cache.join("cobalt").join("calibration.json");

    let fresh = report(&render(&dir, "fresh", &cache, &[]));
    assert_eq!(
        fresh["calibration"]["file"].as_str(),
        default.to_str(),
        "{fresh}"
    );
    assert!(default.is_file());

    std::fs::write(&default, "{\"version\": 1,\n \"entries\": [{\"host\": ").expect("write");
    let o = render(&dir, "damaged", &cache, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    let v = report(&o);
    assert!(
        stderr.contains(&format!("{}:2:", default.display())),
        "{stderr}"
    );
    assert!(stderr.contains("starting a fresh calibration"), "{stderr}");
    assert_eq!(v["calibration"]["loaded_entries"], 0);
    let text = std::fs::read_to_string(&default).expect("the cache");
    assert!(
        serde_json::from_str::<Value>(&text).is_ok(),
        "replaced: {text}"
    );

    let named = dir.join("named.json");
    std::fs::write(&named, "not json").expect("write");
    let flag = ["--calibration", named.to_str().expect("a UTF-8 temp path")];
    let o = render(&dir, "refused", &cache, &flag);
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(&format!("{}:1:", named.display())),
        "{stderr}"
    );
    assert!(!dir.join("refused.png").exists(), "nothing was written");
    assert_eq!(std::fs::read_to_string(&named).expect("kept"), "not json");
}

/// Eight renders of different workloads (the Cornell box at eight details) started together
/// on one calibration file: each merges its entries into the file as it is under the file's
/// lock, so every workload's entries are kept, and no temporary is left.
#[test]
fn concurrent_runs_sharing_a_file_keep_every_entry() {
    let dir = temp_dir("calibration-concurrent");
    let file = dir.join("shared.json");
    let _ = std::fs::remove_file(&file);
    let runs: Vec<_> = (1..=8)
        .map(|i| {
            let scene = format!("builtin:cornell:0.{i}");
            let out = dir.join(format!("c{i}.png"));
            command()
                .args(["render", "--scene", &scene, "--size", "16x16"])
                .args(["--devices", "cpu:2", "--json", "--calibration"])
                .arg(&file)
                .arg("--out")
                .arg(&out)
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .expect("cobalt runs")
        })
        .collect();
    for run in runs {
        let o = run.wait_with_output().expect("cobalt runs");
        let r = report(&o);
        assert!(
            r["calibration"]["written_entries"].as_u64() > Some(0),
            "{r}"
        );
    }
    let text = std::fs::read_to_string(&file).expect("the calibration was written");
    let saved: Value = serde_json::from_str(&text).expect("JSON");
    let mut workloads: Vec<&str> = saved["entries"]
        .as_array()
        .expect("entries")
        .iter()
        .filter_map(|e| e["workload"].as_str())
        .collect();
    workloads.sort_unstable();
    workloads.dedup();
    let expected: Vec<String> = (1..=8)
        .map(|i| format!("builtin:cornell:0.{i} whitted"))
        .collect();
    assert_eq!(workloads, expected);
    let temporaries: Vec<_> = std::fs::read_dir(&dir)
        .expect("list")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(temporaries.is_empty(), "{temporaries:?}");
}
