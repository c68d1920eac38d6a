//! Scenes in any units: a scene whose coordinates are all multiplied by a power of two renders
//! the same image byte for byte, on the CPU and on the GPU, from 2⁻⁶⁰ to 2⁶⁰, with the camera
//! given in the scene's own units too; decimal scales change only the rounding of the
//! vertices; coordinates beyond `f32` are refused. The scenes are built-in ones written out as
//! OBJ files: sparse geometry with triangles of very different sizes side by side (forest) and
//! a closed room with a mirror and a light (cornell).

use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use raytrace::{SceneNeeds, SceneSource};

use crate::testkit::{command, temp_dir};

/// Writes `scene`'s triangles to `path` as OBJ with every coordinate multiplied by `scale`
/// (in `f64`, then rounded to the `f32` the loader reads back exactly).
fn write_obj(scene: &raytrace::Scene, scale: f64, path: &Path) {
    let mut text = String::new();
    for p in &scene.positions {
        let [x, y, z] = p.to_array().map(|c| (f64::from(c) * scale) as f32);
        text += &format!("v {x:e} {y:e} {z:e}\n");
    }
    for t in &scene.triangles {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, text).expect("OBJ written");
}

/// The built-in scene `name` as OBJ files at each scale, in `dir`.
fn scaled_objs(dir: &Path, name: &str, scales: &[f64]) -> Vec<PathBuf> {
    let scene = SceneSource::parse(name)
        .and_then(|s| s.load(SceneNeeds::AO))
        .expect("built-in scene");
    scales
        .iter()
        .map(|&s| {
            let path = dir.join(format!("{}-{s:e}.obj", name.replace(':', "-")));
            write_obj(&scene, s, &path);
            path
        })
        .collect()
}

/// Renders `scene` to a PNG in `dir` and returns the pixels and the JSON report; `extra` adds
/// arguments (devices, camera).
fn render(
    dir: &Path,
    scene: &Path,
    shader: &str,
    extra: &[&str],
) -> Result<(Vec<u8>, serde_json::Value), String> {
    let out = dir.join(format!(
        "{}-{shader}-{}.png",
        scene.file_stem().expect("a file name").to_string_lossy(),
        extra.join("_").replace([':', ','], "-")
    ));
    let o = command()
        .env("COBALT_GPU_SOFTWARE", "1")
        .args(["render", "--shader", shader, "--size", "32x24"])
        .args(["--ao-samples", "4", "--json", "--scene"])
        .arg(scene)
        .arg("--out")
        .arg(&out)
        .args(extra)
        .output()
        .expect("the cobalt binary runs");
    if !o.status.success() {
        return Err(format!(
            "exit {:?}: {}",
            o.status.code(),
            String::from_utf8_lossy(&o.stderr)
        ));
    }
    let pixels = image::open(&out).expect("PNG").to_rgb8().into_raw();
    let report = serde_json::from_slice(&o.stdout).expect("JSON report");
    Ok((pixels, report))
}

/// Powers of two from 2⁻⁶⁰ to 2⁶⁰.
fn powers_of_two(step: i32) -> Vec<f64> {
    (-60..=60)
        .step_by(step as usize)
        .map(|k| 2f64.powi(k))
        .collect()
}

#[test]
fn power_of_two_scales_render_the_same_image_on_the_cpu() {
    let dir = temp_dir("scale-cpu");
    let scales = powers_of_two(20);
    for name in ["builtin:forest:0.02", "builtin:cornell:0.3"] {
        let objs = scaled_objs(&dir, name, &scales);
        let one = scales.iter().position(|&s| s == 1.0).unwrap();
        for shader in ["ao", "whitted"] {
            let (reference, report) =
                render(&dir, &objs[one], shader, &["--devices", "cpu:1"]).unwrap();
            // The orbit camera, given back in each scale's units as `--eye` and `--at`.
            let point = |report: &serde_json::Value, key: &str, s: f64| {
                let v = report[key].as_array().unwrap();
                let c: Vec<String> = v
                    .iter()
                    .map(|c| format!("{:e}", (c.as_f64().unwrap() * s) as f32))
                    .collect();
                c.join(",")
            };
            for (obj, &s) in objs.iter().zip(&scales) {
                let (pixels, r) = render(&dir, obj, shader, &["--devices", "cpu:2"]).unwrap();
                assert_eq!(pixels, reference, "{name} {shader} at {s:e}");
                assert_eq!(r["triangles"], report["triangles"]);
                let (eye, at) = (point(&report, "eye", s), point(&report, "at", s));
                let camera = ["--devices", "cpu:1", "--eye", &eye, "--at", &at];
                let (pixels, r) = render(&dir, obj, shader, &camera).unwrap();
                assert_eq!(pixels, reference, "{name} {shader} at {s:e}, --eye {eye}");
                // The report gives the camera in the units it was given in.
                assert_eq!(point(&r, "eye", 1.0), eye, "{r}");
            }
        }
    }
}

/// The GPU renders a scaled scene as it renders the scene at scale 1, and as the CPU does
/// (lavapipe agrees with the CPU bit for bit). Without any adapter: a note, or a failure
/// when `CI` is set.
#[test]
fn power_of_two_scales_render_the_same_image_on_the_gpu() {
    let dir = temp_dir("scale-gpu");
    let scales = [2f64.powi(-40), 1.0, 2f64.powi(40)];
    let objs = scaled_objs(&dir, "builtin:forest:0.02", &scales);
    for shader in ["ao", "whitted"] {
        let (cpu, _) = render(&dir, &objs[1], shader, &["--devices", "cpu:1"]).unwrap();
        for (obj, s) in objs.iter().zip(scales) {
            match render(&dir, obj, shader, &["--devices", "gpu:0"]) {
                Ok((pixels, _)) => assert_eq!(pixels, cpu, "{shader} at {s:e}"),
                Err(e) if e.contains("no GPU") || e.contains("adapter") => {
                    assert!(
                        std::env::var_os("CI").is_none(),
                        "CI is set but no GPU adapter was found: {e}"
                    );
                    eprintln!("note: no GPU adapter, the GPU half is skipped: {e}");
                    return;
                }
                Err(e) => panic!("{shader} at {s:e}: {e}"),
            }
        }
    }
}

/// Decimal scales round every vertex differently, so a few pixels may change; at 10³⁰ and
/// 10⁻³⁰ the products of the triangle test would leave `f32` without the power-of-two
/// normalisation on loading. Coordinates beyond `f32` are refused with exit 2.
#[test]
fn decimal_and_extreme_scales_render_the_right_image_or_are_refused() {
    let dir = temp_dir("scale-decimal");
    let scales = [1.0, 1e-12, 1e12, 1e-30, 1e30];
    let objs = scaled_objs(&dir, "builtin:forest:0.02", &scales);
    for shader in ["ao", "whitted"] {
        let (reference, _) = render(&dir, &objs[0], shader, &["--devices", "cpu:2"]).unwrap();
        for (obj, s) in objs.iter().zip(scales).skip(1) {
            let (pixels, _) = render(&dir, obj, shader, &["--devices", "cpu:2"])
                .unwrap_or_else(|e| panic!("{shader} at {s:e}: {e}"));
            let close = pixels
                .chunks(3)
                .zip(reference.chunks(3))
                .filter(|(a, b)| a.iter().zip(*b).all(|(x, y)| x.abs_diff(*y) <= 2))
                .count();
            let share = close as f64 / (reference.len() / 3) as f64;
            assert!(share >= 0.99, "{shader} at {s:e}: {share} within 2 levels");
        }
    }
    let huge = dir.join("huge.obj");
    std::fs::write(&huge, "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let o = command()
        .args(["render", "--size", "8x8", "--scene"])
        .arg(&huge)
        .arg("--out")
        .arg(dir.join("huge.png"))
        .output()
        .expect("the cobalt binary runs");
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("huge.obj") && err.contains("1e39"), "{err}");
    assert!(!dir.join("huge.png").exists());
}

/// `cobalt trace` reads rays in the scene's own units: rays scaled with the scene find the
/// same triangles at the same `t`.
#[test]
fn traced_hits_do_not_depend_on_the_units() {
    let dir = temp_dir("scale-trace");
    let scales = [1.0, 2f64.powi(-50), 2f64.powi(50)];
    let objs = scaled_objs(&dir, "builtin:cornell:0.3", &scales);
    let mut reference = None;
    for (obj, s) in objs.iter().zip(scales) {
        // Rays from inside the room in every direction of a coarse grid.
        let mut bytes = Vec::new();
        for i in 0..64 {
            let (a, b) = (f64::from(i % 8) / 8.0 * TAU, f64::from(i / 8) / 8.0 * PI);
            let d = [a.cos() * b.sin(), b.cos(), a.sin() * b.sin()];
            let o = [0.1 * s, 0.2 * s, -0.1 * s];
            for v in o.into_iter().chain(d.map(|c| c * s)) {
                bytes.extend_from_slice(&(v as f32).to_le_bytes());
            }
            bytes.extend_from_slice(&0f32.to_le_bytes());
            bytes.extend_from_slice(&f32::INFINITY.to_le_bytes());
        }
        let (rays, hits) = (
            dir.join(format!("{s:e}.rays")),
            dir.join(format!("{s:e}.hits")),
        );
        std::fs::write(&rays, bytes).unwrap();
        let o = command()
            .args(["trace", "--scene"])
            .arg(obj)
            .arg("--rays")
            .arg(&rays)
            .arg("--out")
            .arg(&hits)
            .output()
            .expect("the cobalt binary runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let got = std::fs::read(&hits).unwrap();
        assert_eq!(got.len(), 64 * 8);
        let reference = reference.get_or_insert(got.clone());
        assert_eq!(&got, reference, "at {s:e}");
    }
}
