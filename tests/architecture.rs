//! ARCHITECTURE.md names only paths that exist: every backticked token that looks like a file
//! or folder of the repository (it has a `/`, or ends in `.rs`, `.wgsl` or `.md`) is found,
//! from the workspace or from one of the crates' source folders. A bare file name (`whitted.rs`)
//! is found if a file of that name lies anywhere in those folders, and `*` in a name matches any
//! run of characters. Tokens inside fenced code blocks and tokens with spaces are not paths.

use std::path::{Path, PathBuf};

/// The folders a path in ARCHITECTURE.md may be relative to: the workspace, then each crate's
/// sources.
const BASES: [&str; 6] = [
    "",
    "sched/src",
    "raytrace/src",
    "collision/src",
    "knn/src",
    "src",
];

/// The backticked tokens of `text` outside fenced code blocks.
fn backticked(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            // Every other piece between backticks is inside a pair.
            out.extend(line.split('`').skip(1).step_by(2));
        }
    }
    out
}

/// Whether `token` names a file or folder rather than code or a command.
fn path_like(token: &str) -> bool {
    !token.contains(char::is_whitespace)
        && (token.contains('/') || [".rs", ".wgsl", ".md"].iter().any(|e| token.ends_with(e)))
}

/// Every file and folder below `dir`, recursively.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        out.push(path.clone());
        if path.is_dir() {
            walk(&path, out);
        }
    }
}

/// Whether `name` matches `pattern`, whose `*`s match any run of characters.
fn matches(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if parts.len() == 1 {
        return name == pattern;
    }
    if !name.starts_with(first) || !name[first.len()..].ends_with(last) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(at) => rest = &rest[at + part.len()..],
            None => return false,
        }
    }
    true
}

/// The tokens of `text` that look like paths and name nothing under `ws`.
fn missing(ws: &Path, text: &str) -> Vec<String> {
    let mut everything = Vec::new();
    for base in &BASES[1..] {
        walk(&ws.join(base), &mut everything);
    }
    backticked(text)
        .into_iter()
        .filter(|t| path_like(t))
        .filter(|token| {
            let path = token.trim_end_matches('/');
            let found = if path.contains('/') {
                BASES.iter().any(|base| {
                    let (dir, name) = path.rsplit_once('/').expect("the path has a `/`");
                    std::fs::read_dir(ws.join(base).join(dir)).is_ok_and(|entries| {
                        entries
                            .flatten()
                            .any(|e| matches(name, &e.file_name().to_string_lossy()))
                    })
                })
            } else {
                everything.iter().any(|f| {
                    f.file_name()
                        .is_some_and(|n| matches(path, &n.to_string_lossy()))
                })
            };
            !found
        })
        .map(str::to_string)
        .collect()
}

#[test]
fn architecture_names_existing_paths() {
    let ws = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(ws.join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let missing = missing(ws, &text);
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md names paths that do not exist: {}",
        missing.join(", ")
    );
}

/// The check itself, on a made-up tree and text: what exists passes, whatever the base it is
/// relative to, and every path that does not is reported, code blocks and prose left alone.
#[test]
fn missing_paths_are_reported() {
    let ws = crate::testkit::temp_dir("architecture");
    std::fs::create_dir_all(ws.join("raytrace/src/gpu/paths")).unwrap();
    std::fs::write(ws.join("raytrace/src/gpu/paths/render.wgsl"), "").unwrap();
    std::fs::write(ws.join("raytrace/src/lib.rs"), "").unwrap();
    let text = "`raytrace/src/lib.rs`, `gpu/paths/`, `render.wgsl`, `gpu/*.wgsl`, `*.wgsl` \
                `gpu/render.wgsl` and `gone.rs`; `a b/c` and `Outputs::check` are not paths.\n\
                ```\nnot/checked.rs\n```\n`src/missing/`";
    assert_eq!(
        missing(&ws, text),
        ["gpu/*.wgsl", "gpu/render.wgsl", "gone.rs", "src/missing/"]
    );
    std::fs::remove_dir_all(&ws).unwrap();
}
