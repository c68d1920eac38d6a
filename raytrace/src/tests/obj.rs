// OBJ loading: file order ids, fan triangulation, materials, and errors that name file and line.

use std::path::PathBuf;

use glam::Vec3;

use crate::{BuildPreset, Bvh, Error, Ray, SceneNeeds, SceneSource};

/// A fresh directory per test (tests run in parallel).
fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cobalt-rt-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

fn write(test: &str, name: &str, body: &[u8]) -> PathBuf {
    let p = dir(test).join(name);
    std::fs::write(&p, body).expect("write temp file");
    p
}

fn load(p: &std::path::Path, needs: SceneNeeds) -> crate::Result<crate::Scene> {
    SceneSource::File(p.to_path_buf()).load(needs)
}

const QUADS: &str = "# two quads and a pentagon\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nv 0.5 1.5 1\n\
o first\nf 1 2 3 4\n\
g second\nf -5 -4 -3 -2 -1\n\
o third\nf 1 2 3\n";

#[test]
fn fan_triangulation_in_file_order() {
    let p = write("fan", "a.obj", QUADS.as_bytes());
    let s = load(&p, SceneNeeds::AO).unwrap();
    assert_eq!(s.len(), 2 + 3 + 1);
    assert_eq!(s.report.faces, 3);
    assert_eq!(s.report.vertices, 9);
    let v = |i| s.vertices(i);
    let p3 = |x, y, z| Vec3::new(x, y, z);
    assert_eq!(v(0), [p3(0., 0., 0.), p3(1., 0., 0.), p3(1., 1., 0.)]);
    assert_eq!(v(1), [p3(0., 0., 0.), p3(1., 1., 0.), p3(0., 1., 0.)]);
    assert_eq!(v(2), [p3(0., 0., 1.), p3(1., 0., 1.), p3(1., 1., 1.)]);
    assert_eq!(v(4), [p3(0., 0., 1.), p3(0., 1., 1.), p3(0.5, 1.5, 1.)]);
    assert_eq!(v(5), v(0));
    assert!(s.normals.is_none() && s.materials.is_empty() && s.lights.is_empty());
}

#[test]
fn materials_normals_and_lights_only_when_asked() {
    let mtl = "newmtl shiny\nKd 0.1 0.2 0.3\nKs 0.9 0.9 0.9\nillum 3\n\
newmtl matte\nKd 0.5 0.5 0.5\nillum 2\n";
    write("mtl", "m.mtl", mtl.as_bytes());
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n\
usemtl shiny\nf 1 2 3\nusemtl matte\nf 1 2 4\nusemtl nosuch\nf 1 3 4\n";
    let p = write("mtl", "a.obj", obj.as_bytes());
    let s = load(&p, SceneNeeds::WHITTED).unwrap();
    assert_eq!(s.material_ids, vec![1, 2, 0]);
    let shiny = s.materials[1];
    assert_eq!(shiny.diffuse, Vec3::new(0.1, 0.2, 0.3));
    assert!((shiny.reflectance - 0.9).abs() < 1e-6);
    assert_eq!(s.materials[2].reflectance, 0.0);
    assert_eq!(s.materials[0].reflectance, crate::DEFAULT_REFLECTANCE);
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.normals.as_ref().map(Vec::len), Some(s.positions.len()));
    let geo = load(&p, SceneNeeds::AO).unwrap();
    assert!(geo.materials.is_empty() && geo.material_ids.is_empty() && geo.lights.is_empty());
}

#[test]
fn missing_mtl_is_a_warning_not_an_error() {
    let p = write(
        "nomtl",
        "a.obj",
        b"mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let s = load(&p, SceneNeeds::WHITTED).unwrap();
    assert_eq!(s.material_ids, vec![0]);
    assert!(!s.report.warnings.is_empty());
}

#[test]
fn latin1_comments_are_fine() {
    let mut body = b"# caf\xe9 \xa9 2009\n".to_vec();
    body.extend_from_slice(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let p = write("latin1", "a.obj", &body);
    assert_eq!(load(&p, SceneNeeds::AO).unwrap().len(), 1);
}

#[test]
fn degenerate_triangles_keep_their_ids_but_stay_out_of_the_bvh() {
    let obj = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\n\
f 1 2 3\nf 1 1 4\nf 1 2 4\n";
    let p = write("degen", "a.obj", obj.as_bytes());
    let s = load(&p, SceneNeeds::AO).unwrap();
    assert_eq!((s.len(), s.report.degenerate), (3, 2));
    let bvh = Bvh::build(&s, BuildPreset::Medium).unwrap();
    assert_eq!(bvh.report().degenerate_skipped, 2);
    crate::bvh::validate(&bvh, &s).unwrap();
    let hit = bvh
        .closest_hit(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z))
        .unwrap();
    assert_eq!(hit.prim, 2);
    // Straight at the collinear one: nothing.
    let r = Ray::new(Vec3::new(1.5, 0.0, 1.0), -Vec3::Z);
    assert!(bvh.closest_hit(&r).is_none());
}

/// Loads `body` and returns the error's message, checking it names the file and `line`.
fn error_at(test: &str, body: &str, line: usize) -> Error {
    let p = write(test, "bad.obj", body.as_bytes());
    let e = load(&p, SceneNeeds::AO).expect_err("should fail");
    let msg = e.to_string();
    assert!(msg.contains(&p.display().to_string()), "{msg}");
    assert!(
        msg.contains(&format!(":{line}:")),
        "expected line {line}: {msg}"
    );
    e
}

#[test]
fn errors_name_file_and_line() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let e = error_at("nan", &format!("{head}v 1 nan 2\nf 1 2 3\n"), 4);
    assert!(matches!(e, Error::NonFinite { .. }));
    let e = error_at("inf", &format!("{head}v inf 0 2\n"), 4);
    assert!(matches!(e, Error::NonFinite { .. }));
    let e = error_at("overflow", &format!("{head}v 1e39 0 2\n"), 4);
    assert!(matches!(e, Error::NonFinite { .. }));
    let e = error_at("range", &format!("{head}f 1 2 3\nf 1 2 4\n"), 5);
    assert!(matches!(
        e,
        Error::IndexOutOfRange {
            index: 4,
            count: 3,
            ..
        }
    ));
    let e = error_at("zero", &format!("{head}f 0 1 2\n"), 4);
    assert!(matches!(e, Error::IndexOutOfRange { index: 0, .. }));
    let e = error_at("neg", &format!("{head}f -1 -2 -4\n"), 4);
    assert!(matches!(e, Error::IndexOutOfRange { index: -4, .. }));
    let e = error_at("forward", "v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n", 2);
    assert!(matches!(e, Error::IndexOutOfRange { .. }));
    let e = error_at("trunc-v", &format!("{head}f 1 2 3\nv 1.0 2.0"), 5);
    assert!(matches!(e, Error::Parse { .. }));
    let e = error_at("trunc-f", &format!("{head}f 1 2 3\nf 1 2"), 5);
    assert!(matches!(e, Error::Parse { .. }));
    let e = error_at("garbled", &format!("{head}v 1.0 abc 2\n"), 4);
    assert!(matches!(e, Error::Parse { .. }));
    let e = error_at("garbled-f", &format!("{head}f 1 x 3\n"), 4);
    assert!(matches!(e, Error::Parse { .. }));
}

#[test]
fn missing_and_empty_files() {
    let p = dir("missing").join("nope.obj");
    let e = load(&p, SceneNeeds::AO).unwrap_err();
    assert!(matches!(e, Error::Io { .. }));
    assert!(e.to_string().contains("nope.obj"), "{e}");
    for (i, body) in ["", "# nothing\n", "v 0 0 0\nv 1 0 0\n"].iter().enumerate() {
        let p = write("empty", &format!("e{i}.obj"), body.as_bytes());
        let e = load(&p, SceneNeeds::AO).unwrap_err();
        assert!(matches!(e, Error::EmptyScene { .. }), "{e}");
        assert!(e.to_string().contains(&format!("e{i}.obj")));
    }
}

#[test]
fn scene_arguments() {
    use crate::builtin::Builtin;
    assert_eq!(
        SceneSource::parse("builtin:forest").unwrap(),
        SceneSource::Builtin {
            kind: Builtin::Forest,
            detail: 1.0
        }
    );
    assert_eq!(
        SceneSource::parse("builtin:hairball:0.25").unwrap(),
        SceneSource::Builtin {
            kind: Builtin::Hairball,
            detail: 0.25
        }
    );
    assert_eq!(
        SceneSource::parse("../x/conference.obj").unwrap(),
        SceneSource::File("../x/conference.obj".into())
    );
    for bad in [
        "builtin:teapot",
        "builtin:forest:x",
        "builtin:forest:0",
        "builtin:forest:-1",
    ] {
        let e = SceneSource::parse(bad).unwrap_err();
        assert!(e.to_string().contains(bad), "{e}");
    }
}

#[test]
fn a_utf8_byte_order_mark_keeps_the_first_line() {
    let p = write(
        "bom",
        "a.obj",
        b"\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let s = load(&p, SceneNeeds::AO).unwrap();
    assert_eq!(s.len(), 1);
    assert_eq!(s.vertices(0)[0], Vec3::ZERO);
}

#[test]
fn utf16_is_refused_naming_the_file() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    for bom in [[0xFF, 0xFE], [0xFE, 0xFF]] {
        let mut body = bom.to_vec();
        for u in text.encode_utf16() {
            body.extend_from_slice(&u.to_le_bytes());
        }
        let p = write("utf16", "a.obj", &body);
        let e = load(&p, SceneNeeds::AO).unwrap_err();
        assert!(matches!(e, Error::Encoding { .. }), "{e}");
        assert!(e.to_string().contains("a.obj"), "{e}");
    }
}

#[test]
fn latin1_outside_comments_is_refused_with_its_line() {
    let body = b"v 0 0 0\nv 1 0 0\nv 0 1 0\ng caf\xe9\nf 1 2 3\n";
    let p = write("latin1-name", "a.obj", body);
    let e = load(&p, SceneNeeds::AO).unwrap_err().to_string();
    assert!(e.contains("a.obj") && e.contains("line 4"), "{e}");
}

/// A valid OBJ text, to be mutated.
const TRIANGLES: &str = "# a fan\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\n\
o fan\nf 1 2 3\nf 2 4 3\nf 1//1 2//1 4//1\n";

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]

    /// Random bytes load or fail with an error; they never panic.
    #[test]
    fn random_bytes_never_panic(body in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..512)) {
        let p = write("prop-random", "a.obj", &body);
        let _ = load(&p, SceneNeeds::WHITTED);
    }

    /// A valid file with bytes overwritten, inserted or cut: an error, or a scene whose BVH
    /// builds and validates.
    #[test]
    fn mutated_files_never_panic(
        edits in proptest::collection::vec((0usize..200, proptest::prelude::any::<u8>(), 0u8..3), 1..8)
    ) {
        let mut body = TRIANGLES.as_bytes().to_vec();
        for (at, byte, op) in edits {
            let at = at % (body.len() + 1);
            match op {
                0 if at < body.len() => body[at] = byte,
                1 => body.insert(at, byte),
                _ if at < body.len() => { body.remove(at); }
                _ => {}
            }
        }
        let p = write("prop-mutated", "a.obj", &body);
        if let Ok(scene) = load(&p, SceneNeeds::WHITTED) {
            let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
            crate::bvh::validate(&bvh, &scene).unwrap();
        }
    }
}
