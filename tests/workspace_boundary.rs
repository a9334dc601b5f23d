//! The workspace's architecture invariants, checked on the code itself rather than stated only in
//! ARCHITECTURE.md:
//!
//! 1. `rockwatch-core` (the functional core) depends, directly or transitively, on no transport,
//!    async runtime, signal, terminal or plotting crate; the shell depends on the core and never
//!    the reverse, and neither does the tests' harness the core's tests use (read from `cargo
//!    metadata`, i.e. from the Cargo.toml files and Cargo.lock).
//! 2. No module imports one that imports it back, at any level of either crate's module tree
//!    (read from the `crate::`/`super::` paths of the sources; a module may use its ancestors
//!    and descendants, as `record::mseed::reader` uses `record::Record`).
//! 3. The core's public functions report failure with typed errors, never `Result<_, String>`
//!    (read from the sources' `pub fn` signatures).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Crates the core must never pull in, even indirectly.
const FORBIDDEN_IN_CORE: [&str; 10] = [
    "ros2-client",
    "rustdds",
    "iceoryx2",
    "mio",
    "tokio",
    "signal-hook",
    "anyhow",
    "indicatif",
    "plotters",
    "clap",
];

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn metadata() -> serde_json::Value {
    let out = Command::new(env!("CARGO"))
        .args(["metadata", "--format-version", "1", "--locked"])
        .current_dir(repo_root())
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON")
}

/// Package name of a resolve-graph node id (`path+file:///…#rockwatch-core@0.1.0` or
/// `registry+https://…#mio@1.0.4`), looked up in the package list.
fn names_by_id(meta: &serde_json::Value) -> BTreeMap<String, String> {
    meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| {
            (
                p["id"].as_str().expect("id").to_owned(),
                p["name"].as_str().expect("name").to_owned(),
            )
        })
        .collect()
}

/// Every package reachable from `root` through normal (non-dev, non-build) dependencies.
fn normal_closure(meta: &serde_json::Value, root: &str) -> BTreeSet<String> {
    let names = names_by_id(meta);
    let nodes = meta["resolve"]["nodes"].as_array().expect("resolve graph");
    let deps_of: BTreeMap<&str, Vec<&str>> = nodes
        .iter()
        .map(|n| {
            let normal = n["deps"]
                .as_array()
                .expect("deps")
                .iter()
                .filter(|d| {
                    d["dep_kinds"]
                        .as_array()
                        .expect("dep_kinds")
                        .iter()
                        .any(|k| k["kind"].is_null())
                })
                .map(|d| d["pkg"].as_str().expect("pkg"))
                .collect();
            (n["id"].as_str().expect("id"), normal)
        })
        .collect();
    let root_id = names
        .iter()
        .find(|(_, name)| name.as_str() == root)
        .map(|(id, _)| id.clone())
        .unwrap_or_else(|| panic!("package {root} is in the workspace"));
    let mut seen = BTreeSet::new();
    let mut stack = vec![root_id];
    while let Some(id) = stack.pop() {
        if seen.insert(id.clone()) {
            stack.extend(deps_of[id.as_str()].iter().map(|d| (*d).to_owned()));
        }
    }
    seen.iter().map(|id| names[id].clone()).collect()
}

#[test]
fn the_workspace_has_the_core_and_the_shell() {
    let meta = metadata();
    let members: BTreeSet<String> = meta["workspace_members"]
        .as_array()
        .expect("workspace_members")
        .iter()
        .map(|id| names_by_id(&meta)[id.as_str().expect("id")].clone())
        .collect();
    assert_eq!(
        members,
        BTreeSet::from([
            "rockwatch".to_owned(),
            "rockwatch-core".to_owned(),
            "rockwatch-test-harness".to_owned()
        ])
    );
}

#[test]
fn the_core_depends_on_no_transport_runtime_or_terminal_crate() {
    let meta = metadata();
    let core = normal_closure(&meta, "rockwatch-core");
    let leaked: Vec<&str> = FORBIDDEN_IN_CORE
        .iter()
        .copied()
        .filter(|c| core.contains(*c))
        .collect();
    assert!(leaked.is_empty(), "rockwatch-core pulls in {leaked:?}");
    assert!(!core.contains("rockwatch"), "the core depends on the shell");
    // The core's tests build without the shell: their harness does not depend on it.
    let harness = normal_closure(&meta, "rockwatch-test-harness");
    assert!(harness.contains("rockwatch-core"), "{harness:?}");
    assert!(
        !harness.contains("rockwatch"),
        "the test harness (a dev-dependency of the core) depends on the shell"
    );
    // The check can fail: the shell does pull in what the core must not.
    let shell = normal_closure(&meta, "rockwatch");
    for c in ["rockwatch-core", "ros2-client", "iceoryx2", "mio", "anyhow"] {
        assert!(shell.contains(c), "the shell should depend on {c}");
    }
}

#[test]
fn every_test_bench_and_example_file_is_declared_by_a_crate() {
    // Targets are declared explicitly (autotests = false): a file nobody declares would never
    // build or run, silently.
    let meta = metadata();
    let members: BTreeSet<&str> = meta["workspace_members"]
        .as_array()
        .expect("workspace_members")
        .iter()
        .filter_map(|id| id.as_str())
        .collect();
    let declared: BTreeSet<PathBuf> = meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .filter(|p| p["id"].as_str().is_some_and(|id| members.contains(id)))
        .flat_map(|p| p["targets"].as_array().expect("targets").iter())
        .map(|t| {
            Path::new(t["src_path"].as_str().expect("src_path"))
                .canonicalize()
                .expect("target source exists")
        })
        .collect();
    let root = repo_root();
    let mut files = Vec::new();
    for dir in ["tests", "benches"] {
        for entry in std::fs::read_dir(root.join(dir)).expect("directory") {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    for entry in std::fs::read_dir(root.join("examples")).expect("examples/") {
        let dir = entry.expect("entry").path();
        if dir.is_dir() {
            files.push(dir.join("main.rs"));
        }
    }
    assert!(files.len() > 30, "{files:?}");
    let missing: Vec<&PathBuf> = files
        .iter()
        .filter(|f| !declared.contains(&f.canonicalize().expect("file exists")))
        .collect();
    assert!(
        missing.is_empty(),
        "not declared by any Cargo.toml: {missing:?}"
    );
}

// ------------------------------------------------------------------ module graph

/// Module path of a source file relative to its crate's `src/` (`a/b.rs` and `a/b/mod.rs` →
/// `["a", "b"]`; `lib.rs` and `main.rs` → the root).
fn module_of(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let file = parts.pop().expect("a file name");
    let stem = file.trim_end_matches(".rs");
    if !matches!(stem, "mod" | "lib" | "main") {
        parts.push(stem.to_owned());
    }
    parts
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("source directory") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The paths named after `crate::`, `super::` or `self::` in `code` (comments removed), as
/// segment lists relative to `module`; `{a, b::c}` groups are expanded.
fn referenced_paths(code: &str, module: &[String]) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let bytes = code.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let rest = &code[i..];
        let boundary = i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_');
        let start: Option<Vec<String>> = if !boundary {
            None
        } else if rest.starts_with("crate::") {
            i += "crate::".len();
            Some(Vec::new())
        } else if rest.starts_with("super::") || rest.starts_with("self::") {
            let mut base = module.to_vec();
            while code[i..].starts_with("super::") || code[i..].starts_with("self::") {
                if code[i..].starts_with("super::") {
                    base.pop();
                    i += "super::".len();
                } else {
                    i += "self::".len();
                }
            }
            Some(base)
        } else {
            None
        };
        match start {
            Some(base) => {
                let (paths, next) = parse_tree(code, i, base);
                out.extend(paths);
                i = next.max(i + 1);
            }
            None => i += rest.chars().next().map_or(1, char::len_utf8),
        }
    }
    out
}

/// Parses `a::b::{c, d::e}` at `at`, prefixed by `base`; returns the full paths and the end.
fn parse_tree(code: &str, mut at: usize, base: Vec<String>) -> (Vec<Vec<String>>, usize) {
    let bytes = code.as_bytes();
    let mut path = base;
    loop {
        let s = at;
        while at < bytes.len() && (bytes[at].is_ascii_alphanumeric() || bytes[at] == b'_') {
            at += 1;
        }
        if at > s {
            path.push(code[s..at].to_owned());
        }
        let group = if code[at..].starts_with("::{") {
            Some(3)
        } else if at == s && code[at..].starts_with('{') {
            Some(1) // `crate::{…}`
        } else {
            None
        };
        if let Some(skip) = group {
            at += skip;
            let mut all = Vec::new();
            loop {
                while at < bytes.len() && (bytes[at] as char).is_whitespace() {
                    at += 1;
                }
                if at >= bytes.len() || bytes[at] == b'}' {
                    return (all, at + 1);
                }
                let (paths, next) = parse_tree(code, at, path.clone());
                all.extend(paths);
                at = next;
                while at < bytes.len() && (bytes[at] as char).is_whitespace() {
                    at += 1;
                }
                if at < bytes.len() && bytes[at] == b',' {
                    at += 1;
                }
            }
        } else if code[at..].starts_with("::") {
            at += 2;
        } else {
            return (vec![path], at);
        }
    }
}

fn strip_comments(source: &str) -> String {
    source
        .lines()
        .map(|l| match l.find("//") {
            Some(k) if !l[..k].contains('"') => &l[..k],
            _ => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Edges between sibling modules at every level: a use of `b::x` inside `a::y` is the edge
/// `a → b` among the children of their common ancestor (uses of ancestors or descendants are
/// not edges).
fn sibling_edges(src: &Path) -> BTreeSet<(Vec<String>, Vec<String>)> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeSet<Vec<String>> = files
        .iter()
        .map(|f| module_of(f.strip_prefix(src).expect("under src")))
        .collect();
    let mut edges = BTreeSet::new();
    for file in &files {
        let module = module_of(file.strip_prefix(src).expect("under src"));
        let code = strip_comments(&std::fs::read_to_string(file).expect("readable source"));
        for path in referenced_paths(&code, &module) {
            // The longest prefix of `path` that is a module of this crate.
            let Some(target) = (0..=path.len())
                .rev()
                .map(|k| path[..k].to_vec())
                .find(|p| modules.contains(p))
            else {
                continue;
            };
            let common = module
                .iter()
                .zip(&target)
                .take_while(|(a, b)| a == b)
                .count();
            if common == module.len() || common == target.len() {
                continue; // ancestor or descendant
            }
            edges.insert((module[..=common].to_vec(), target[..=common].to_vec()));
        }
    }
    edges
}

/// A cycle in the directed graph `edges`, if any.
fn find_cycle(edges: &BTreeSet<(Vec<String>, Vec<String>)>) -> Option<Vec<String>> {
    let mut next: BTreeMap<&Vec<String>, Vec<&Vec<String>>> = BTreeMap::new();
    for (a, b) in edges {
        next.entry(a).or_default().push(b);
    }
    fn visit<'a>(
        node: &'a Vec<String>,
        next: &BTreeMap<&'a Vec<String>, Vec<&'a Vec<String>>>,
        done: &mut BTreeSet<&'a Vec<String>>,
        stack: &mut Vec<&'a Vec<String>>,
    ) -> Option<Vec<String>> {
        if let Some(k) = stack.iter().position(|n| *n == node) {
            let mut cycle: Vec<String> = stack[k..].iter().map(|m| m.join("::")).collect();
            cycle.push(node.join("::"));
            return Some(cycle);
        }
        if !done.insert(node) {
            return None;
        }
        stack.push(node);
        for n in next.get(node).into_iter().flatten() {
            if let Some(c) = visit(n, next, done, stack) {
                return Some(c);
            }
        }
        stack.pop();
        None
    }
    let mut done = BTreeSet::new();
    for start in next.keys() {
        if let Some(c) = visit(start, &next, &mut done, &mut Vec::new()) {
            return Some(c);
        }
    }
    None
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let mut cycles = Vec::new();
    for krate in ["rockwatch-core", "rockwatch"] {
        let src = repo_root().join("crates").join(krate).join("src");
        let edges = sibling_edges(&src);
        assert!(!edges.is_empty(), "{krate}: no module edges found");
        if let Some(cycle) = find_cycle(&edges) {
            cycles.push(format!("{krate}: {}", cycle.join(" → ")));
        }
    }
    assert!(cycles.is_empty(), "import cycles: {cycles:?}");
}

#[test]
fn the_cycle_check_sees_a_cycle() {
    // The parser and the search on a made-up pair of modules that import each other.
    let a = vec!["a".to_owned()];
    let paths = referenced_paths("use crate::{b::X, c};\nuse super::d::{e, f::G};", &a);
    let expected: Vec<Vec<String>> = [
        vec!["b", "X"],
        vec!["c"],
        vec!["d", "e"],
        vec!["d", "f", "G"],
    ]
    .iter()
    .map(|p| p.iter().map(|s| (*s).to_owned()).collect())
    .collect();
    assert_eq!(paths, expected);
    let edges = BTreeSet::from([
        (vec!["a".to_owned()], vec!["b".to_owned()]),
        (vec!["b".to_owned()], vec!["c".to_owned()]),
        (vec!["c".to_owned()], vec!["a".to_owned()]),
    ]);
    assert_eq!(
        find_cycle(&edges),
        Some(vec!["a".into(), "b".into(), "c".into(), "a".into()])
    );
}

// ------------------------------------------------------------------ typed errors

/// The `pub fn` signatures of `code` (from `pub fn` to the body's `{` or the `;`) that return
/// `Result<_, String>`, with their first line.
fn string_error_signatures(code: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find("pub fn ") {
        let tail = &rest[at..];
        let end = tail.find(['{', ';']).unwrap_or(tail.len());
        let signature: String = tail[..end].split_whitespace().collect::<Vec<_>>().join(" ");
        if let Some(ret) = signature.split("->").nth(1) {
            let ret = ret.replace(' ', "");
            if ret.starts_with("Result<") && ret.trim_end().ends_with(",String>") {
                found.push(signature.clone());
            }
        }
        rest = &tail[end.max(1)..];
    }
    found
}

#[test]
fn the_core_s_public_functions_return_typed_errors() {
    let mut files = Vec::new();
    rust_files(&repo_root().join("crates/rockwatch-core/src"), &mut files);
    assert!(files.len() > 50, "{files:?}");
    let offenders: Vec<String> = files
        .iter()
        .flat_map(|f| {
            let code = std::fs::read_to_string(f).expect("source file");
            string_error_signatures(&code)
                .into_iter()
                .map(move |s| format!("{}: {s}", f.display()))
        })
        .collect();
    assert!(
        offenders.is_empty(),
        "public functions of the core returning Result<_, String>: {offenders:#?}"
    );
}

#[test]
fn the_shell_s_public_functions_return_typed_errors() {
    let root = repo_root();
    let mut files = Vec::new();
    rust_files(&root.join("crates/rockwatch/src"), &mut files);
    assert!(files.len() > 50, "{files:?}");
    let offenders: Vec<String> = files
        .iter()
        .flat_map(|f| {
            let code = std::fs::read_to_string(f).expect("source file");
            let relative = f.strip_prefix(&root).unwrap_or(f).display().to_string();
            string_error_signatures(&code)
                .into_iter()
                .map(move |s| format!("{relative}: {s}"))
        })
        .collect();
    assert!(
        offenders.is_empty(),
        "public functions of the shell returning Result<_, String> (give them a thiserror \
         type): {offenders:#?}"
    );
}

#[test]
fn the_typed_error_check_sees_a_string_error() {
    let code = "pub fn a(x: &str) -> Result<u8, String> { todo!() }\n\
                pub fn b(\n    x: u8,\n) -> Result<Vec<f64>, String> {}\n\
                fn private() -> Result<(), String> {}\n\
                pub fn c() -> Result<u8, MyError> {}\n\
                pub fn d() -> Option<String> {}\n";
    let found = string_error_signatures(code);
    assert_eq!(found.len(), 2, "{found:?}");
    assert!(found[0].starts_with("pub fn a(") && found[1].starts_with("pub fn b("));
}
