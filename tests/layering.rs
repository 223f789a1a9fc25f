//! The module layering, read from src/: every `crate::` path of each top-level module (test
//! code and comments left out) is an edge. The stages run input → kernel → eval → reference → measure → analyse
//! → report, under the app layer; an edge from a stage to a later one is an upward
//! edge, and the report imports neither measure nor the app layer. The graph must have no
//! circle and no upward edge, with no exception. Inside the folders, the files' own import
//! graph (`crate::` and `super::` paths) must have no circle either.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Each top-level entry of src/ (a stage folder, or one of the few cross-cutting files) and
/// its stage, in order. An entry missing here fails the test: a new one is placed on purpose.
const STAGES: &[(&str, &[&str])] = &[
    // Cross-cutting: every file is written through `io`; `limits` holds the caps.
    ("base", &["io", "limits", "tuning", "warnings"]),
    // Case files, sampler, scene, targets, LTC tables, names.
    ("input", &["input"]),
    // Kernel files, their composition and validation, the methods they define.
    ("kernel", &["kernel"]),
    // The CPU evaluator (naga IR interpreted in f32 and f64) and the op counts.
    ("eval", &["eval"]),
    // The f64 references, independent of the kernels.
    ("reference", &["reference"]),
    // GPU runs, sweeps, searches, bench times, scans, eval rows.
    ("measure", &["measure"]),
    ("analyse", &["analyse"]),
    ("report", &["report"]),
    // One module per command.
    ("app", &["app"]),
];

/// The text of a file without `//` comments and without a trailing `#[cfg(test)] mod tests`.
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines()
        .map(|l| l.find("//").map_or(l, |i| &l[..i]))
        .collect::<Vec<_>>()
        .join("\n")
}

fn ident(s: &str) -> &str {
    let end = s
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    &s[..end]
}

/// The top-level modules named after each `crate::` in `code`, `crate::{a, b::c}` included.
fn imports(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let (mut depth, mut start) = (0usize, 0usize);
            for (j, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        out.insert(ident(group[start..j].trim()).to_string());
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.insert(ident(group[start..j].trim()).to_string());
                        start = j + 1;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident(rest).to_string());
        }
    }
    out.retain(|m| !m.is_empty() && m != "self");
    out
}

fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            walk(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Module → the modules it imports, for every file of src/ but main.rs and test files.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&src, &mut files);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap();
        let name = rel.file_name().unwrap().to_string_lossy();
        if rel == Path::new("main.rs") || rel == Path::new("lib.rs") || name == "tests.rs" || name == "testing.rs" {
            continue;
        }
        let first = rel.components().next().unwrap().as_os_str().to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        let text = std::fs::read_to_string(&f).unwrap();
        let entry = g.entry(module.clone()).or_default();
        for m in imports(&code(&text)) {
            if m != module {
                entry.insert(m);
            }
        }
    }
    g
}

fn stage_of(module: &str) -> Option<usize> {
    STAGES.iter().position(|(_, ms)| ms.contains(&module))
}

/// A circle through `from`, if any: the path back to it.
fn circle(g: &BTreeMap<String, BTreeSet<String>>, from: &str) -> Option<Vec<String>> {
    fn go(
        g: &BTreeMap<String, BTreeSet<String>>,
        at: &str,
        goal: &str,
        path: &mut Vec<String>,
        seen: &mut BTreeSet<String>,
    ) -> bool {
        for next in g.get(at).into_iter().flatten() {
            if next == goal {
                path.push(next.clone());
                return true;
            }
            if seen.insert(next.clone()) {
                path.push(next.clone());
                if go(g, next, goal, path, seen) {
                    return true;
                }
                path.pop();
            }
        }
        false
    }
    let mut path = vec![from.to_string()];
    go(g, from, from, &mut path, &mut BTreeSet::new()).then_some(path)
}

#[test]
fn the_scanner_reads_paths_and_groups() {
    let found = imports(&code(
        "use crate::a::X;\nuse crate::{b, c::{D, E}, self};\nfn f() { crate::d::g(); } // crate::z\n",
    ));
    assert_eq!(found.into_iter().collect::<Vec<_>>(), ["a", "b", "c", "d"]);
}

#[test]
fn modules_keep_to_their_stages_and_form_no_circle() {
    let g = graph();
    assert!(g.len() >= 9, "src/ read: {:?}", g.keys());
    let unplaced: Vec<&String> = g.keys().filter(|m| stage_of(m).is_none()).collect();
    assert!(unplaced.is_empty(), "modules without a stage in STAGES: {unplaced:?}");

    let mut problems = Vec::new();
    for (from, tos) in &g {
        let s = stage_of(from).unwrap();
        for to in tos {
            let Some(t) = stage_of(to) else {
                problems.push(format!("{from} → {to}: `{to}` has no stage"));
                continue;
            };
            if t > s {
                problems.push(format!(
                    "{from} ({}) → {to} ({}): an upward edge",
                    STAGES[s].0, STAGES[t].0
                ));
            }
            if STAGES[s].0 == "report" && matches!(STAGES[t].0, "measure" | "app") {
                problems.push(format!(
                    "report → {to}: the report imports neither measure nor the app layer"
                ));
            }
        }
    }
    for m in g.keys() {
        if let Some(path) = circle(&g, m) {
            problems.push(format!("a circle: {}", path.join(" → ")));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The module path of a file: src/a/b.rs and src/a/b/mod.rs are `a::b`.
fn module_of(rel: &Path) -> String {
    let mut parts: Vec<String> = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
    let last = parts.pop().unwrap();
    if last != "mod.rs" {
        parts.push(last.trim_end_matches(".rs").to_string());
    }
    parts.join("::")
}

/// The longest known module that `path` (`a::b::c::Item`) names.
fn resolve(path: &[&str], known: &BTreeSet<String>) -> Option<String> {
    (1..=path.len())
        .rev()
        .map(|n| path[..n].join("::"))
        .find(|m| known.contains(m))
}

/// File-level modules → the modules they import (`crate::` and `super::` paths), for every
/// file of src/ but main.rs, lib.rs and test files; an import from the file's own ancestor
/// module is left out (see [`ancestor_edges`]).
fn file_graph() -> BTreeMap<String, BTreeSet<String>> {
    file_edges().0
}

/// [`file_graph`], and the edges it leaves out: a file importing from one of its ancestor
/// modules (`interp/exec.rs` from `interp/mod.rs`). The ancestor declares the child and uses
/// it, so the two depend on each other: a circle the file graph cannot see.
fn ancestor_edges() -> BTreeMap<String, BTreeSet<String>> {
    file_edges().1
}

type Graph = BTreeMap<String, BTreeSet<String>>;

fn file_edges() -> (Graph, Graph) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&src, &mut files);
    let mut texts = Vec::new();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap().to_path_buf();
        let name = rel.file_name().unwrap().to_string_lossy().into_owned();
        if rel == Path::new("main.rs") || rel == Path::new("lib.rs") || name == "tests.rs" || name == "testing.rs" {
            continue;
        }
        texts.push((module_of(&rel), code(&std::fs::read_to_string(&f).unwrap())));
    }
    let known: BTreeSet<String> = texts.iter().map(|(m, _)| m.clone()).collect();
    let mut g: Graph = BTreeMap::new();
    let mut up: Graph = BTreeMap::new();
    for (module, text) in &texts {
        g.entry(module.clone()).or_default();
        let parent: Vec<&str> = module.split("::").collect();
        let parent = &parent[..parent.len() - 1];
        for (prefix, base) in [("crate::", Vec::new()), ("super::", parent.to_vec())] {
            let mut rest = text.as_str();
            while let Some(i) = rest.find(prefix) {
                // `super::super::` and `self::` are not used in this crate's imports.
                let before = &rest[..i];
                rest = &rest[i + prefix.len()..];
                if prefix == "super::" && before.ends_with("::") {
                    continue;
                }
                let end = rest
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'))
                    .unwrap_or(rest.len());
                let mut path: Vec<&str> = base.clone();
                path.extend(rest[..end].split("::").filter(|p| !p.is_empty()));
                if let Some(m) = resolve(&path, &known) {
                    if module.starts_with(&format!("{m}::")) {
                        up.entry(module.clone()).or_default().insert(m);
                    } else if &m != module {
                        g.entry(module.clone()).or_default().insert(m);
                    }
                }
            }
        }
    }
    (g, up)
}

/// The folders whose files import nothing from their ancestor modules (the others still do:
/// a folder joins the list once its `mod.rs` holds only what its children do not need).
const NO_ANCESTOR_IMPORTS: &[&str] = &["eval"];

#[test]
fn no_file_imports_from_its_parent_module_in_the_listed_folders() {
    let up = ancestor_edges();
    assert!(!up.is_empty(), "the scanner sees no ancestor edge at all: {up:?}");
    let found: Vec<String> = up
        .iter()
        .filter(|(from, _)| NO_ANCESTOR_IMPORTS.iter().any(|f| from.starts_with(&format!("{f}::"))))
        .map(|(from, to)| format!("{from} → {}", to.iter().cloned().collect::<Vec<_>>().join(", ")))
        .collect();
    assert!(
        found.is_empty(),
        "files importing from their ancestor module (which declares and uses them):\n{}",
        found.join("\n")
    );
}

#[test]
fn no_circle_between_files_either() {
    let g = file_graph();
    assert!(g.contains_key("input::ltc::fit"), "src/ read: {:?}", g.keys());
    let circles: Vec<String> = g
        .keys()
        .filter_map(|m| circle(&g, m))
        .map(|path| path.join(" → "))
        .collect();
    assert!(
        circles.is_empty(),
        "import circles between files:\n{}",
        circles.join("\n")
    );
}
