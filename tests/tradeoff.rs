#[test]
fn tradeoff_reports_both_tables_and_error_falls_with_samples() {
    let json = crate::testkit::temp_dir("tradeoff").join("t.json");
    let o = crate::testkit::command()
        .args([
            "tradeoff",
            "--scene",
            "builtin:cornell:0.2",
            "--size",
            "24x24",
        ])
        .args(["--presets", "fastest,medium", "--ao-samples", "1,16"])
        .args(["--reference", "256", "--json"])
        .arg(&json)
        .output()
        .expect("the cobalt binary runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("| medium |"), "{text}");
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("valid JSON");
    let presets = v["presets"].as_array().expect("presets");
    assert_eq!(presets.len(), 2);
    for p in presets {
        assert!(p["build_seconds"].as_f64().is_some_and(|s| s >= 0.0));
        assert!(p["primary_mrays_per_s"].as_f64().is_some_and(|s| s > 0.0));
        assert!(p["ao_mrays_per_s"].as_f64().is_some_and(|s| s > 0.0));
    }
    let ao = v["ao"].as_array().expect("ao");
    let rmse: Vec<f64> = ao
        .iter()
        .map(|a| a["rmse"].as_f64().expect("rmse"))
        .collect();
    // 16 probes per pixel are far closer to the reference than one.
    assert!(rmse[1] < 0.6 * rmse[0] && rmse[0] > 0.0, "{rmse:?}");

    let bad = crate::testkit::cobalt(&["tradeoff", "--ao-samples", "1,zero"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("'zero' for '--ao-samples"));
}
