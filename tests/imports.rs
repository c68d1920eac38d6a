//! The modules of each crate import each other in one direction: no file depends, through any
//! chain of imports, on a file that depends on it. A cycle makes two modules one concept in
//! two files, which neither can be read, tested or moved without the other.
//!
//! The check reads the sources, not the compiler's view: from each crate root it follows the
//! `mod` declarations (leaving out `#[cfg(test)]` items and modules named `tests`, whose code
//! may import freely), collects the paths each file names (`use` declarations and paths in code
//! that start at `crate`, `super`, `self`, an imported module or a child module), and resolves
//! each to the file that defines the item, following re-exports to their source. A file
//! depends on those files. A `pub use` counts only where the file itself uses the name, so a
//! parent that re-exports its children's items does not depend on them for that. Comments,
//! doc comments and string literals are not read; methods defined in another file's `impl`
//! block are not seen.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use crate::testkit::{Rng, temp_dir};

/// The crate roots of the workspace, relative to it.
const ROOTS: [&str; 5] = [
    "sched/src/lib.rs",
    "raytrace/src/lib.rs",
    "collision/src/lib.rs",
    "knn/src/lib.rs",
    "src/main.rs",
];

/// A module: a file, or an inline `mod name { … }` within one.
struct Module {
    /// Its path from the crate root.
    path: Vec<String>,
    file: usize,
    parent: Option<usize>,
    /// The folder its file modules live in.
    dir: PathBuf,
    children: HashMap<String, usize>,
    /// Names brought in by `use`, each with its path as written.
    imports: HashMap<String, Vec<String>>,
}

/// One crate's modules, and the paths each file names.
#[derive(Default)]
struct Tree {
    files: Vec<PathBuf>,
    modules: Vec<Module>,
    /// (module, path as written, the name a `pub use` binds) for every path named.
    paths: Vec<(usize, Vec<String>, Option<String>)>,
    /// The identifiers each file uses outside its `use` declarations.
    idents: Vec<BTreeSet<String>>,
}

/// The tokens of Rust source that paths are made of: identifiers, `::` and single punctuation
/// characters. Comments, strings, characters and lifetimes are dropped.
fn tokens(src: &str) -> Vec<String> {
    let c: Vec<char> = src.chars().collect();
    let at = |i: usize| c.get(i).copied().unwrap_or('\0');
    // Index of the first `pat` at or after `i` (the end when there is none).
    let find = |i: usize, pat: &[char]| (i..c.len()).find(|&j| c[j..].starts_with(pat));
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        let word = |i: usize| at(i).is_alphanumeric() || at(i) == '_';
        i = if ch == '/' && at(i + 1) == '/' {
            find(i, &['\n']).unwrap_or(c.len())
        } else if ch == '/' && at(i + 1) == '*' {
            find(i, &['*', '/']).map_or(c.len(), |j| j + 2)
        } else if ch == '"' {
            let mut j = i + 1;
            while j < c.len() && c[j] != '"' {
                j += if c[j] == '\\' { 2 } else { 1 };
            }
            j + 1
        } else if ch == '\'' && at(i + 1) == '\\' {
            find(i + 2, &['\'']).map_or(c.len(), |j| j + 1)
        } else if ch == '\'' {
            // A character ('x') has its closing quote two on; a lifetime ('a) has none.
            if at(i + 2) == '\'' { i + 3 } else { i + 1 }
        } else if word(i) {
            let start = i;
            while word(i) {
                i += 1;
            }
            let hashes = c[i..].iter().take_while(|&&h| h == '#').count();
            let raw = matches!(c[start..i], ['r'] | ['b', 'r']) && at(i + hashes) == '"';
            if raw {
                // A raw string: up to a quote followed by as many `#`.
                let close: Vec<char> = std::iter::once('"').chain(vec!['#'; hashes]).collect();
                find(i + hashes + 1, &close).map_or(c.len(), |j| j + close.len())
            } else {
                out.push(c[start..i].iter().collect());
                // A raw identifier (`r#name`): its `#` starts no attribute.
                if c[start..i] == ['r'] && hashes > 0 {
                    i + 1
                } else {
                    i
                }
            }
        } else if ch == ':' && at(i + 1) == ':' {
            out.push("::".into());
            i + 2
        } else {
            if !ch.is_whitespace() {
                out.push(ch.to_string());
            }
            i + 1
        };
    }
    out
}

/// Index of the bracket closing the one at `i`.
fn matching(t: &[String], mut i: usize) -> usize {
    let mut depth = 0;
    while i < t.len() {
        match t[i].as_str() {
            "(" | "[" | "{" => depth += 1,
            ")" | "]" | "}" if depth == 1 => return i,
            ")" | "]" | "}" => depth -= 1,
            _ => {}
        }
        i += 1;
    }
    i
}

/// Index past the item, field or statement starting at `i`: its `;` or `,`, or the `}` closing
/// its first `{`, outside brackets; or up to the bracket closing the one it is in.
fn item_end(t: &[String], mut i: usize) -> usize {
    while i < t.len() {
        match t[i].as_str() {
            ";" | "," => return i + 1,
            "{" => return matching(t, i) + 1,
            "}" | ")" | "]" => return i,
            "(" | "[" => i = matching(t, i),
            _ => {}
        }
        i += 1;
    }
    i
}

/// The paths of the use tree at `t[*i..]`, each with the name it binds; `*i` ends past it.
fn use_tree(
    t: &[String],
    i: &mut usize,
    mut path: Vec<String>,
    out: &mut Vec<(Vec<String>, String)>,
) {
    while *i < t.len() {
        let tok = t[*i].clone();
        *i += 1;
        match tok.as_str() {
            "::" if path.is_empty() => path.push(tok),
            "::" => {}
            "{" => {
                while *i < t.len() && t[*i] != "}" {
                    use_tree(t, i, path.clone(), out);
                    *i += usize::from(t[*i] == ",");
                }
                *i += 1;
                return;
            }
            _ => {
                // `self` in braces names the path so far; at the start, this module.
                if tok != "self" || path.is_empty() {
                    path.push(tok);
                }
                if t.get(*i).is_some_and(|s| s == "::") {
                    continue;
                }
                let mut name = path.last().cloned().unwrap_or_default();
                if t.get(*i).is_some_and(|s| s == "as") {
                    name = t[*i + 1].clone();
                    *i += 2;
                }
                out.push((path, name));
                return;
            }
        }
    }
}

impl Tree {
    /// Reads the crate whose root file is `root`, following its `mod` declarations.
    fn read(root: &Path) -> Tree {
        let mut tree = Tree::default();
        let dir = root.parent().expect("a crate root has a folder");
        tree.file(root, None, Vec::new(), dir.to_path_buf());
        tree
    }

    fn file(&mut self, path: &Path, parent: Option<usize>, module: Vec<String>, dir: PathBuf) {
        let src = std::fs::read_to_string(path);
        let src = src.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        self.files.push(path.to_path_buf());
        self.idents.push(BTreeSet::new());
        let t = tokens(&src);
        let m = self.module(self.files.len() - 1, parent, module, dir);
        self.items(&t, 0, t.len(), m);
    }

    fn module(
        &mut self,
        file: usize,
        parent: Option<usize>,
        path: Vec<String>,
        dir: PathBuf,
    ) -> usize {
        let id = self.modules.len();
        if let (Some(p), Some(name)) = (parent, path.last()) {
            self.modules[p].children.insert(name.clone(), id);
        }
        let (children, imports) = (HashMap::new(), HashMap::new());
        self.modules.push(Module {
            path,
            file,
            parent,
            dir,
            children,
            imports,
        });
        id
    }

    /// Reads the tokens `t[i..end]` of module `m`.
    fn items(&mut self, t: &[String], mut i: usize, end: usize, m: usize) {
        let file = self.modules[m].file;
        let mut test_only = false;
        while i < end {
            let (tok, next) = (t[i].as_str(), t.get(i + 1).map_or("", String::as_str));
            if tok == "#" {
                let close = matching(t, if next == "!" { i + 2 } else { i + 1 });
                test_only |= close >= 4 && t[close - 4..close] == ["cfg", "(", "test", ")"];
                i = close + 1;
            } else if test_only || tok == "mod" && next == "tests" {
                (test_only, i) = (false, item_end(t, i));
            } else if tok == "mod" {
                let path = [self.modules[m].path.clone(), vec![next.to_string()]].concat();
                let dir = self.modules[m].dir.join(next);
                if t[i + 2] == "{" {
                    let close = matching(t, i + 2);
                    let child = self.module(file, Some(m), path, dir);
                    self.items(t, i + 3, close, child);
                    i = close + 1;
                } else {
                    let flat = self.modules[m].dir.join(format!("{next}.rs"));
                    let source = if flat.exists() {
                        flat
                    } else {
                        dir.join("mod.rs")
                    };
                    self.file(&source, Some(m), path, dir);
                    i += 3;
                }
            } else if tok == "use" {
                let public =
                    i > 0 && t[i - 1] == "pub" || i > 3 && t[i - 1] == ")" && t[i - 4] == "pub";
                let mut bound = Vec::new();
                i += 1;
                use_tree(t, &mut i, Vec::new(), &mut bound);
                for (path, name) in bound {
                    if name != "*" && name != "_" {
                        self.modules[m].imports.insert(name.clone(), path.clone());
                    }
                    self.paths.push((m, path, public.then_some(name)));
                }
            } else if (matches!(tok, "crate" | "super" | "self") || next == "::")
                && (i == 0 || t[i - 1] != "::")
            {
                let mut path = vec![tok.to_string()];
                i += 1;
                while t[i] == "::"
                    && t[i + 1].starts_with(|c: char| c.is_alphanumeric() || c == '_')
                {
                    path.push(t[i + 1].clone());
                    i += 2;
                }
                self.idents[file].extend(path.iter().cloned());
                self.paths.push((m, path, None));
            } else {
                self.idents[file].insert(tok.to_string());
                i += 1;
            }
        }
    }

    /// `path` as written in module `m`, made absolute; `None` for another crate's or a local
    /// item's path.
    fn absolute(&self, m: usize, path: &[String], depth: usize) -> Option<Vec<String>> {
        let (first, rest) = path.split_first()?;
        let module = &self.modules[m];
        let base = match first.as_str() {
            "crate" => Vec::new(),
            "self" => module.path.clone(),
            "super" => {
                // The parent's own path, or its parent's for `super::super`.
                let up = if rest.first().is_some_and(|s| s == "super") {
                    Vec::new()
                } else {
                    vec!["self".into()]
                };
                return self.absolute(module.parent?, &[up, rest.to_vec()].concat(), depth);
            }
            name if module.children.contains_key(name) => {
                [module.path.clone(), vec![name.into()]].concat()
            }
            name => {
                let target = module.imports.get(name)?;
                if depth > 16 || target[..] == [name] {
                    return None;
                }
                self.absolute(m, target, depth + 1)?
            }
        };
        Some([base, rest.to_vec()].concat())
    }

    /// The module an absolute path ends in, following re-exports, and whether the path names
    /// that module itself rather than an item in it.
    fn resolve(&self, path: &[String], depth: usize) -> Option<(usize, bool)> {
        let mut m = 0;
        for (k, seg) in path.iter().enumerate() {
            if let Some(&child) = self.modules[m].children.get(seg) {
                m = child;
            } else if let Some(target) = self.modules[m].imports.get(seg).filter(|_| depth < 16) {
                let next = [self.absolute(m, target, 0)?, path[k + 1..].to_vec()].concat();
                return self.resolve(&next, depth + 1);
            } else {
                return Some((m, false));
            }
        }
        Some((m, true))
    }

    /// The files each file depends on, each edge with the first path that makes it.
    fn edges(&self) -> BTreeMap<(usize, usize), String> {
        let mut edges = BTreeMap::new();
        for (m, path, reexport) in &self.paths {
            let file = self.modules[*m].file;
            if reexport
                .as_ref()
                .is_some_and(|name| !self.idents[file].contains(name))
            {
                continue;
            }
            let resolved = self
                .absolute(*m, path, 0)
                .and_then(|abs| self.resolve(&abs, 0));
            if let Some((to, false)) = resolved
                && self.modules[to].file != file
            {
                let to = self.modules[to].file;
                edges.entry((file, to)).or_insert_with(|| path.join("::"));
            }
        }
        edges
    }
}

/// The sets of more than one file of the crate whose root is `root` that reach each other
/// through their imports, each with the imports that join its files.
fn cycles(root: &Path) -> Vec<(Vec<PathBuf>, Vec<String>)> {
    let tree = Tree::read(root);
    let edges = tree.edges();
    let n = tree.files.len();
    let reach: Vec<BTreeSet<usize>> = (0..n)
        .map(|from| {
            let (mut seen, mut todo) = (BTreeSet::new(), vec![from]);
            while let Some(a) = todo.pop() {
                let next = edges.keys().filter(|e| e.0 == a).map(|e| e.1);
                todo.extend(next.filter(|&b| seen.insert(b)));
            }
            seen
        })
        .collect();
    let sets: BTreeSet<Vec<usize>> = (0..n)
        .map(|a| {
            (0..n)
                .filter(|&b| a == b || reach[a].contains(&b) && reach[b].contains(&a))
                .collect()
        })
        .filter(|set: &Vec<usize>| set.len() > 1)
        .collect();
    sets.into_iter()
        .map(|set| {
            let via = edges
                .iter()
                .filter(|((a, b), _)| set.contains(a) && set.contains(b));
            let show = |f: &usize| tree.files[*f].display().to_string();
            let via = via.map(|((a, b), path)| format!("{} -> {} ({path})", show(a), show(b)));
            (
                set.iter().map(|&f| tree.files[f].clone()).collect(),
                via.collect(),
            )
        })
        .collect()
}

#[test]
fn workspace_imports_are_acyclic() {
    let ws = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut report = String::new();
    for root in ROOTS {
        for (files, via) in cycles(&ws.join(root)) {
            let names: Vec<_> = files
                .iter()
                .map(|f| f.strip_prefix(ws).unwrap_or(f).display().to_string())
                .collect();
            report += &format!(
                "import cycle through {}:\n  {}\n",
                names.join(", "),
                via.join("\n  ")
            );
        }
    }
    assert!(report.is_empty(), "{report}");
}

/// Random crates whose imports are known, written in every form the check reads (a `use`, a
/// path in code, through a re-export of the root, relative with `super`), with noise it must
/// not read: the files it finds in cycles are exactly those that reach each other.
#[test]
fn finds_exactly_the_cycles_written() {
    let mut rng = Rng::from_env(7);
    let mut with_cycles = 0;
    for round in 0..40 {
        let n = 2 + rng.below(7);
        let dir = temp_dir(&format!("imports-{round}"));
        std::fs::create_dir_all(dir.join("nest")).unwrap();
        // Module `k` is `mK.rs`, or `nest/mK.rs` for odd `k`.
        let module = |k: usize| {
            if k.is_multiple_of(2) {
                format!("m{k}")
            } else {
                format!("nest::m{k}")
            }
        };
        let (mut lib, mut nest) = ("mod nest;\n".to_string(), String::new());
        let mut reach = vec![vec![false; n]; n];
        for (a, row) in reach.iter_mut().enumerate() {
            lib += &format!("pub use {}::Item{a};\n", module(a));
            if a.is_multiple_of(2) {
                lib += &format!("mod m{a};\n");
            } else {
                nest += &format!("pub mod m{a};\n");
            }
            let mut src = format!(
                "pub struct Item{a};\n// crate::m0::Item0\nconst S: &str = \"crate::m0::Item0\";\n"
            );
            // Mostly downward imports, which close no cycle, and a few upward ones.
            let deps: Vec<usize> = (0..n)
                .filter(|&b| b != a && rng.unit() < if b < a { 0.3 } else { 0.08 })
                .collect();
            for b in deps {
                row[b] = true;
                let up = if a.is_multiple_of(2) {
                    "super"
                } else {
                    "super::super"
                };
                src += &match rng.below(4) {
                    0 => format!("use crate::{}::Item{b};\n", module(b)),
                    1 => format!("fn f{b}() {{ let _ = crate::{}::Item{b}; }}\n", module(b)),
                    2 => format!("use crate::Item{b} as Other{b};\n"),
                    _ => format!("use {up}::{}::{{self, Item{b}}};\n", module(b)),
                };
            }
            let file = if a.is_multiple_of(2) {
                format!("m{a}.rs")
            } else {
                format!("nest/m{a}.rs")
            };
            std::fs::write(dir.join(file), src).unwrap();
        }
        std::fs::write(dir.join("lib.rs"), lib).unwrap();
        std::fs::write(dir.join("nest/mod.rs"), nest).unwrap();
        // Floyd–Warshall's closure, then the sets of modules that reach each other.
        for k in 0..n {
            for a in 0..n {
                for b in 0..n {
                    reach[a][b] |= reach[a][k] && reach[k][b];
                }
            }
        }
        let want: BTreeSet<Vec<usize>> = (0..n)
            .map(|a| {
                (0..n)
                    .filter(|&b| a == b || reach[a][b] && reach[b][a])
                    .collect()
            })
            .filter(|set: &Vec<usize>| set.len() > 1)
            .collect();
        let number = |f: &PathBuf| {
            f.file_stem().unwrap().to_str().unwrap()[1..]
                .parse()
                .unwrap()
        };
        let got: BTreeSet<Vec<usize>> = cycles(&dir.join("lib.rs"))
            .iter()
            .map(|(files, _)| {
                let mut set: Vec<usize> = files.iter().map(number).collect();
                set.sort();
                set
            })
            .collect();
        assert_eq!(
            got,
            want,
            "round {round}, imports {reach:?} in {}",
            dir.display()
        );
        with_cycles += usize::from(!want.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
    // Both outcomes were checked, not only the acyclic one.
    assert!(
        (1..40).contains(&with_cycles),
        "{with_cycles} of 40 rounds had cycles"
    );
}
