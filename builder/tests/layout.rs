//! The builder's top-level modules form no cycle: each may use only modules
//! that do not use it back (ARCHITECTURE.md, "Builder modules"). Test code
//! and comments are not counted.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Which top-level modules each top-level module's own (non-test) code names.
fn dependencies(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut deps = BTreeMap::new();
    for entry in std::fs::read_dir(src).unwrap().map(Result::unwrap) {
        let path = entry.path();
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        if name == "lib" || name == "testing" {
            continue;
        }
        let files: Vec<_> = if path.is_dir() { rust_files(&path) } else { vec![path.clone()] };
        let used: &mut BTreeSet<String> = deps.entry(name.clone()).or_default();
        for file in files.iter().filter(|f| f.file_name().unwrap() != "tests.rs") {
            let text = std::fs::read_to_string(file).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap();
            for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
                for (k, _) in line.match_indices("crate::") {
                    let module: String = line[k + 7..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                    if module != name && !module.is_empty() {
                        used.insert(module);
                    }
                }
            }
        }
    }
    deps
}

fn rust_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap().map(Result::unwrap) {
        let path = entry.path();
        if path.is_dir() {
            out.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out
}

/// A cycle through `start`, if any, as the modules along it.
fn cycle_from(deps: &BTreeMap<String, BTreeSet<String>>, start: &str) -> Option<Vec<String>> {
    let mut stack = vec![vec![start.to_string()]];
    let mut seen = BTreeSet::new();
    while let Some(trail) = stack.pop() {
        for next in deps.get(trail.last().unwrap()).into_iter().flatten() {
            if next == start {
                return Some([trail.clone(), vec![next.clone()]].concat());
            }
            if seen.insert(next.clone()) {
                stack.push([trail.clone(), vec![next.clone()]].concat());
            }
        }
    }
    None
}

#[test]
fn the_top_level_modules_form_no_cycle() {
    let deps = dependencies(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(deps.len() >= 10 && deps["render"].contains("tracer") && deps["plan"].contains("raycast"), "the scan finds the modules: {deps:?}");
    for module in deps.keys() {
        assert_eq!(cycle_from(&deps, module), None, "a cycle among the builder's top-level modules");
    }
}

#[test]
fn a_cycle_is_found() {
    let deps: BTreeMap<String, BTreeSet<String>> = [("a", vec!["b"]), ("b", vec!["c"]), ("c", vec!["a"]), ("d", vec!["a"])]
        .map(|(k, v)| (k.into(), v.into_iter().map(String::from).collect()))
        .into();
    assert_eq!(cycle_from(&deps, "a"), Some(vec!["a".into(), "b".into(), "c".into(), "a".into()]));
    assert_eq!(cycle_from(&deps, "d"), None);
}
