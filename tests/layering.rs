//! The shape of the library, read from its source: dependencies run one
//! way (no import circle between the top-level modules of `src/`, nor
//! between the files and folders side by side inside any module's folder), the
//! format at the bottom imports nothing of the crate, the frame-source trait
//! does not know the openers, no function runs past 80 lines and no file
//! past 800.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            out.extend(rust_files(&p));
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// A file's text without `//` comments (doc comments included), so that a
/// link in a comment is no dependency.
fn code_of(path: &Path) -> String {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Top-level module of each file (`src/X.rs` or `src/X/...`), the binary left out.
fn module_of(path: &Path) -> Option<String> {
    let rel = path.strip_prefix(src()).ok()?;
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    let name = first.trim_end_matches(".rs").to_string();
    (name != "bin" && name != "lib").then_some(name)
}

/// The names after each `crate::` in `code`.
fn crate_refs(code: &str) -> BTreeSet<String> {
    code.match_indices("crate::")
        .map(|(i, m)| code[i + m.len()..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect())
        .collect()
}

/// Module -> the modules it uses.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let files = rust_files(&src());
    let modules: BTreeSet<String> = files.iter().filter_map(|f| module_of(f)).collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = modules.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    for f in &files {
        let Some(m) = module_of(f) else { continue };
        for r in crate_refs(&code_of(f)) {
            if r != m && modules.contains(&r) {
                g.get_mut(&m).unwrap().insert(r);
            }
        }
    }
    g
}

/// A path that leads from `from` back to itself, if any.
fn cycle_through(g: &BTreeMap<String, BTreeSet<String>>, from: &str) -> Option<Vec<String>> {
    let mut stack = vec![vec![from.to_string()]];
    let mut seen = BTreeSet::new();
    while let Some(path) = stack.pop() {
        let last = path.last().unwrap();
        for next in &g[last] {
            if next == from {
                return Some([path.clone(), vec![next.clone()]].concat());
            }
            if seen.insert(next.clone()) {
                stack.push([path.clone(), vec![next.clone()]].concat());
            }
        }
    }
    None
}

#[test]
fn no_import_circle_between_modules() {
    let g = graph();
    assert!(g.len() > 10, "found only {:?}", g.keys());
    let cycles: Vec<Vec<String>> = g.keys().filter_map(|m| cycle_through(&g, m)).collect();
    assert!(cycles.is_empty(), "import circles: {cycles:?}");
    // The bottom and a few edges that must run downwards.
    assert!(g["format"].is_empty(), "format uses {:?}", g["format"]);
    for (upper, lower) in [("codec", "solve"), ("solve", "grid"), ("geometry_image", "param"), ("error", "format")] {
        assert!(g[upper].contains(lower) && !g[lower].contains(upper), "{upper} -> {lower}");
    }
}

#[test]
fn the_check_finds_a_circle() {
    // The check itself fails where it should.
    let mut g = graph();
    g.get_mut("format").unwrap().insert("codec".into());
    assert!(cycle_through(&g, "format").is_some());
}

/// The names a `prefix` (`super::`, `crate::codec::encode::`) is followed
/// by in `code`, with each name of a `prefix{a, b::c}` group.
fn names_after(code: &str, prefix: &str) -> BTreeSet<String> {
    let ident = |t: &str| t.trim().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect::<String>();
    let mut out = BTreeSet::new();
    for (i, _) in code.match_indices(prefix) {
        // `super::super::x` from a deeper file is `super::x` of the parent's.
        if i > 0 && code[..i].ends_with("::") {
            continue;
        }
        let rest = &code[i + prefix.len()..];
        if rest.starts_with("super::") {
            continue;
        }
        match rest.strip_prefix('{') {
            Some(group) => out.extend(group.split('}').next().unwrap_or("").split(',').map(ident)),
            None => {
                out.insert(ident(rest));
            }
        }
    }
    out
}

/// The sibling files and folders of each module folder under `src/`
/// (`mod.rs` is the folder itself, not a sibling) and, for each, the
/// siblings it uses: `super::X` from a file directly inside,
/// `super::super::X` from a file one folder deeper, or `crate::PATH::X`.
fn folder_graphs() -> BTreeMap<String, BTreeMap<String, BTreeSet<String>>> {
    let mut out = BTreeMap::new();
    let mut dirs = vec![src()];
    while let Some(dir) = dirs.pop() {
        let entries: Vec<PathBuf> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
        dirs.extend(entries.iter().filter(|p| p.is_dir()).cloned());
        let rel = dir.strip_prefix(src()).unwrap().to_str().unwrap().replace('/', "::");
        if rel.is_empty() || rel.starts_with("bin") {
            continue; // the top level is no_import_circle_between_modules's
        }
        let stem = |p: &Path| p.file_stem().unwrap().to_str().unwrap().to_string();
        let siblings: BTreeSet<String> = entries
            .iter()
            .filter(|p| p.is_dir() || p.extension().is_some_and(|e| e == "rs"))
            .map(|p| stem(p))
            .filter(|n| n != "mod")
            .collect();
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for entry in entries.iter().filter(|p| siblings.contains(&stem(p))) {
            let files = if entry.is_dir() { rust_files(entry) } else { vec![entry.clone()] };
            let mut uses = BTreeSet::new();
            for f in files {
                let code = code_of(&f);
                let depth = f.parent().unwrap().components().count() - dir.components().count();
                let up = ["super::", "super::super::", "super::super::super::"][depth.min(2)];
                uses.extend(names_after(&code, up));
                uses.extend(names_after(&code, &format!("crate::{rel}::")));
            }
            uses.retain(|u| siblings.contains(u) && *u != stem(entry));
            g.insert(stem(entry), uses);
        }
        out.insert(rel, g);
    }
    out
}

#[test]
fn no_import_circle_inside_a_module_folder() {
    let all = folder_graphs();
    assert!(all.contains_key("codec::encode") && all.contains_key("format"), "{:?}", all.keys());
    let mut cycles = Vec::new();
    for (folder, g) in &all {
        cycles.extend(g.keys().filter_map(|m| cycle_through(g, m)).map(|c| format!("{folder}: {c:?}")));
    }
    assert!(cycles.is_empty(), "import circles: {cycles:#?}");
    // The check sees these folders' edges (it reads what it should).
    assert!(all["codec::encode"]["analyse"].contains("plan"), "{:?}", all["codec::encode"]);
}

#[test]
fn the_folder_check_finds_a_circle() {
    let code =
        "use super::{plan::Plan, simulate};\nfn f() { super::super::x::y(); crate::codec::encode::header::h(); }";
    assert_eq!(names_after(code, "super::"), ["plan", "simulate"].map(String::from).into());
    assert_eq!(names_after(code, "crate::codec::encode::"), ["header"].map(String::from).into());
    let mut all = folder_graphs();
    let g = all.get_mut("codec::encode").unwrap();
    g.get_mut("plan").unwrap().insert("analyse".into());
    assert!(cycle_through(g, "plan").is_some());
}

#[test]
fn the_frame_source_trait_does_not_know_the_openers() {
    let code = code_of(&src().join("mesh/source.rs"));
    for opener in ["open", "obj", "gltf_in", "builtin", "topology"] {
        assert!(!code.contains(&format!("super::{opener}")), "mesh/source.rs uses {opener}");
    }
}

/// Functions longer than `limit` lines: (lines, file, name).
fn long_functions(code: &str, limit: usize) -> Vec<(usize, String)> {
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let t = l.trim_start();
        let indent = &l[..l.len() - t.len()];
        let t = t.trim_start_matches("pub(crate) ").trim_start_matches("pub(super) ").trim_start_matches("pub ");
        let t = t.trim_start_matches("async ").trim_start_matches("unsafe ").trim_start_matches("const ");
        let Some(rest) = t.strip_prefix("fn ") else { continue };
        if l.trim_end().ends_with(';') {
            continue;
        }
        let close = format!("{indent}}}");
        if let Some(end) = lines[i + 1..].iter().position(|m| *m == close) {
            if end + 2 > limit {
                out.push((end + 2, rest.split(['(', '<']).next().unwrap_or("").to_string()));
            }
        }
    }
    out
}

#[test]
fn no_function_runs_past_80_lines() {
    let mut long = Vec::new();
    for f in rust_files(&src()) {
        for (n, name) in long_functions(&std::fs::read_to_string(&f).unwrap(), 80) {
            long.push(format!("{}: {name} ({n} lines)", f.strip_prefix(src()).unwrap().display()));
        }
    }
    assert!(long.is_empty(), "{long:#?}");
    // The count itself works.
    let body: String = (0..120).map(|i| format!("    let x{i} = {i};\n")).collect();
    assert_eq!(long_functions(&format!("fn big() {{\n{body}}}\n"), 100), [(122, "big".to_string())]);
}

#[test]
fn no_source_file_runs_past_800_lines() {
    let long: Vec<String> = rust_files(&src())
        .into_iter()
        .filter_map(|f| {
            let n = std::fs::read_to_string(&f).unwrap().lines().count();
            (n > 800).then(|| format!("{}: {n} lines", f.strip_prefix(src()).unwrap().display()))
        })
        .collect();
    assert!(long.is_empty(), "{long:#?}");
    assert!(rust_files(&src()).len() > 50, "the check reads the sources");
}
