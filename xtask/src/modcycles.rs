//! No import cycles between the modules of a crate: for every library crate of the workspace,
//! each source file is a module (`src/a/b.rs` or `src/a/b/mod.rs` = `a::b`), its edges are the
//! `crate::...` and `super::...` paths it names (outside inline `mod x { ... }` bodies, such as
//! test modules), resolved to the longest known module. A module naming its own ancestor or
//! descendant is structure (a parent declares and re-exports its children), not an edge. The
//! check fails on any strongly connected set of two or more modules that is not in
//! [`ALLOWED`], and on an [`ALLOWED`] entry that no longer exists, so the list only shrinks.

use anyhow::{bail, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Cycles that exist outside this check's lane, to be broken by their owners: (crate dir,
/// modules of the cycle, sorted).
pub const ALLOWED: &[(&str, &[&str])] = &[];

/// Crates checked: every workspace package with a library.
const CRATES: &[&str] = &[
    ".",
    "motionctl",
    "xtask",
    "host-tests",
    "boards/contract",
    "boards/drivers",
    "boards/stm32f405",
    "boards/netduinoplus2",
    "boards/f405-motion",
    "firmware",
];

pub fn check(root: &Path) -> Result<()> {
    let mut found = Vec::new();
    for krate in CRATES {
        let src = root.join(krate).join("src");
        if !src.is_dir() {
            continue;
        }
        let files = module_files(&src)?;
        let graph = graph(&files);
        for cycle in cycles(&graph) {
            found.push((krate.to_string(), cycle));
        }
    }
    let mut errors = Vec::new();
    for (krate, cycle) in &found {
        let allowed = ALLOWED.iter().any(|(k, m)| k == krate && m.iter().eq(cycle.iter()));
        let names = cycle.join(" <-> ");
        if allowed {
            println!("  allowed (to be broken by its owner): {krate}: {names}");
        } else {
            errors.push(format!("{krate}: import cycle {names}"));
        }
    }
    for (k, m) in ALLOWED {
        if !found.iter().any(|(fk, fc)| fk == k && m.iter().eq(fc.iter())) {
            errors.push(format!(
                "{k}: allowed cycle {} is gone: remove it from ALLOWED",
                m.join(" <-> ")
            ));
        }
    }
    if !errors.is_empty() {
        bail!("{}", errors.join("\n"));
    }
    println!("  {} crates, no import cycles but the {} allowed", CRATES.len(), ALLOWED.len());
    Ok(())
}

/// Module path (`""` = crate root) -> its source text, for every `.rs` under `src` but `bin/`.
fn module_files(src: &Path) -> Result<BTreeMap<String, String>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![src.to_path_buf()];
    while let Some(dir) = todo.pop() {
        for entry in std::fs::read_dir(&dir)? {
            let path = entry?.path();
            if path.is_dir() {
                if path != src.join("bin") {
                    todo.push(path);
                }
            } else if path.extension().is_some_and(|e| e == "rs") {
                if let Some(m) = module_of(src, &path) {
                    out.insert(m, std::fs::read_to_string(&path)?);
                }
            }
        }
    }
    Ok(out)
}

fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel: PathBuf = file.strip_prefix(src).ok()?.with_extension("");
    let mut parts: Vec<String> =
        rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        parts.pop();
    }
    Some(parts.join("::"))
}

fn parent(m: &str) -> String {
    m.rsplit_once("::").map_or(String::new(), |(p, _)| p.to_string())
}

fn is_ancestor(a: &str, b: &str) -> bool {
    a.is_empty() || b == a || b.starts_with(&format!("{a}::"))
}

/// The file's text without comments and without inline `mod name { ... }` bodies.
fn outside_inline_mods(text: &str) -> String {
    let mut out = String::new();
    let mut skip_until: Option<String> = None;
    for line in text.lines() {
        if let Some(end) = &skip_until {
            if line == end {
                skip_until = None;
            }
            continue;
        }
        let t = line.trim_start();
        let is_mod =
            t.starts_with("mod ") || t.starts_with("pub mod ") || t.starts_with("pub(crate) mod ");
        if is_mod && t.trim_end().ends_with('{') {
            let indent = &line[..line.len() - t.len()];
            skip_until = Some(format!("{indent}}}"));
            continue;
        }
        let code = line.split("//").next().unwrap_or("");
        out.push_str(code);
        out.push('\n');
    }
    out
}

/// Paths named after `crate::` / `super::` (a `{a, b::c}` group gives each), as segments from
/// the crate root.
fn named_paths(module: &str, text: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let bytes: Vec<char> = text.chars().collect();
    let s: String = bytes.iter().collect();
    for (i, _) in s.match_indices("crate::").chain(s.match_indices("super::")) {
        // Only at the start of a path.
        if i > 0 {
            let prev = s[..i].chars().next_back().unwrap_or(' ');
            if prev.is_alphanumeric() || prev == '_' || prev == ':' {
                continue;
            }
        }
        let mut base: Vec<String> = Vec::new();
        let mut rest = &s[i..];
        if let Some(r) = rest.strip_prefix("crate::") {
            rest = r;
        } else {
            let mut m = module.to_string();
            while let Some(r) = rest.strip_prefix("super::") {
                m = parent(&m);
                rest = r;
            }
            base = m.split("::").filter(|p| !p.is_empty()).map(str::to_string).collect();
        }
        for tail in expand(rest) {
            let mut p = base.clone();
            p.extend(tail);
            out.push(p);
        }
    }
    out
}

/// `a::b::X` -> [[a, b, X]]; `{a, b::c}` -> [[a], [b, c]] (one level of grouping).
fn expand(rest: &str) -> Vec<Vec<String>> {
    let ident = |s: &str| -> Vec<String> {
        let end =
            s.find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).unwrap_or(s.len());
        s[..end].split("::").filter(|p| !p.is_empty()).map(str::to_string).collect()
    };
    let head = ident(rest);
    let after = &rest[head.iter().map(|h| h.len() + 2).sum::<usize>().min(rest.len())..];
    if let Some(group) = after.strip_prefix('{').or_else(|| rest.strip_prefix('{')) {
        let body = group.split('}').next().unwrap_or("");
        return body
            .split(',')
            .map(|item| {
                let mut p = head.clone();
                p.extend(ident(item.trim()));
                p
            })
            .collect();
    }
    vec![head]
}

/// Module -> modules it names (neither its ancestor nor its descendant).
fn graph(files: &BTreeMap<String, String>) -> BTreeMap<String, BTreeSet<String>> {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, text) in files {
        let edges = g.entry(m.clone()).or_default();
        for path in named_paths(m, &outside_inline_mods(text)) {
            let mut target = String::new();
            for n in 1..=path.len() {
                let cand = path[..n].join("::");
                if files.contains_key(&cand) {
                    target = cand;
                }
            }
            if !is_ancestor(&target, m) && !is_ancestor(m, &target) {
                edges.insert(target);
            }
        }
    }
    g
}

/// Strongly connected sets of two or more modules (Tarjan), each sorted.
fn cycles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        let i = t.index.len();
        t.index.insert(v, i);
        t.low.insert(v, i);
        t.stack.push(v);
        t.on.insert(v);
        for w in t.g.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low[v];
                t.low.insert(v, lv.min(lw));
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low[v];
                t.low.insert(v, lv.min(iw));
            }
        }
        if t.low[v] == t.index[v] {
            let mut scc = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                scc.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if scc.len() > 1 {
                scc.sort();
                t.out.push(scc);
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn files(list: &[(&str, &str)]) -> BTreeMap<String, String> {
        list.iter().map(|(m, t)| (m.to_string(), t.to_string())).collect()
    }

    #[test]
    fn a_temporary_cycle_is_found() {
        let f = files(&[
            ("", "mod a; mod b; mod c;"),
            ("a", "use crate::b::Thing;"),
            ("b", "use crate::{c::Other, x};"),
            ("c", "fn f() { super::a::g() }"),
        ]);
        assert_eq!(cycles(&graph(&f)), [["a", "b", "c"]]);
    }

    #[test]
    fn parents_children_tests_and_comments_are_not_edges() {
        let f = files(&[
            ("", "pub mod link; pub mod b;"),
            ("link", "mod session; pub use session::Link; use crate::b::B;"),
            ("link::session", "use super::*; use crate::link::Motion;"),
            ("b", "// use crate::link::Link;\n#[cfg(test)]\nmod tests {\n    use crate::link::Link;\n}\n"),
        ]);
        assert!(cycles(&graph(&f)).is_empty());
        assert_eq!(graph(&f)["link"], BTreeSet::from(["b".to_string()]));
    }

    #[test]
    fn modules_come_from_file_paths() {
        let src = Path::new("/x/src");
        assert_eq!(module_of(src, Path::new("/x/src/lib.rs")).unwrap(), "");
        assert_eq!(module_of(src, Path::new("/x/src/link/mod.rs")).unwrap(), "link");
        assert_eq!(module_of(src, Path::new("/x/src/link/feed.rs")).unwrap(), "link::feed");
    }
}
