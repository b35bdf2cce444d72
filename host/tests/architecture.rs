//! The architecture, checked (`docs/architecture.md`, `docs/architecture.md`): every
//! file of `host/src` sits on a floor, uses only its own floor and those
//! below, and is in no import cycle; no source file of the project is over
//! 800 lines.
//!
//! The floors are declared here, in [`FLOORS`], and nowhere else. A file
//! on no floor fails the test until it is given one. The check reads the
//! sources as text: a dependency is a `crate::`/`super::` path (or, in a
//! `mod.rs`, a path through one of its own child modules) outside comments
//! and `#[cfg(test)]` code, resolved to the file of the longest module it
//! names.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The floors, lowest first: a module path prefix, its floor, and the
/// floor's name. Within a floor modules may use each other (without a
/// cycle); a floor uses only the floors below it.
const FLOORS: &[(&str, u8, &str)] = &[
    // 1. Values and time.
    ("assets", 1, "values and time"),
    ("clock", 1, "values and time"),
    ("error", 1, "values and time"),
    ("executor", 1, "values and time"),
    ("parallel", 1, "values and time"),
    ("limiter", 1, "values and time"),
    ("limits", 1, "values and time"),
    ("panics", 1, "values and time"),
    ("payload", 1, "values and time"),
    ("ports", 1, "values and time"),
    ("realtime", 1, "values and time"),
    ("script", 1, "values and time"),
    ("suggest", 1, "values and time"),
    ("trace", 1, "values and time"),
    ("watchdog", 1, "values and time"),
    ("wit_names", 1, "values and time"),
    // 2. The host interfaces plugins import.
    ("capability", 2, "capabilities"),
    // 3. Loading components and live instances.
    ("plugin", 3, "plugins"),
    // 4. The run loop, state and routing.
    ("scheduler", 4, "scheduler"),
    // 5. The system, its builder and handle, deliberative components.
    ("system", 5, "system"),
    // 6. Edges.
    ("example", 6, "edges"),
    ("manifest", 6, "edges"),
    ("network", 6, "edges"),
    ("testing", 6, "edges"),
    ("timeline", 6, "edges"),
    ("view", 6, "edges"),
    ("workspace", 6, "edges"),
    // 7. The command line (the `radar` binary's own crate).
    ("cli", 7, "command line"),
    ("main", 7, "command line"),
    // The library's root only declares modules and re-exports: nothing may
    // import from it.
    ("lib", 8, "the crate's root"),
];

/// One source file: its path under `src`, its module path, and what it
/// depends on (target file, the text that makes it, its line).
struct File {
    rel: String,
    module: Vec<String>,
    uses: Vec<(String, String, usize)>,
}

fn module_of(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(String::from)
        .collect();
    if matches!(parts.last().map(String::as_str), Some("mod")) {
        parts.pop();
    }
    parts
}

fn floor_of(module: &[String]) -> Option<(u8, &'static str)> {
    let top = module.first().map(String::as_str).unwrap_or("lib");
    FLOORS
        .iter()
        .find(|(name, _, _)| *name == top)
        .map(|(_, floor, name)| (*floor, *name))
}

/// The code of a file: its `#[cfg(test)]` part and comments left out, a
/// `use` statement that spans lines joined onto its first line.
fn code(text: &str) -> Vec<(usize, String)> {
    let without_tests = text.split("#[cfg(test)]").next().unwrap_or_default();
    let mut lines: Vec<(usize, String)> = Vec::new();
    let mut open_use = false;
    for (i, line) in without_tests.lines().enumerate() {
        let line = line.split("//").next().unwrap_or_default();
        match lines.last_mut() {
            Some((_, last)) if open_use => last.push_str(line.trim()),
            _ => lines.push((i + 1, line.to_string())),
        }
        let current = &lines
            .last()
            .map(|(_, l)| l.trim_start().to_string())
            .unwrap_or_default();
        let is_use = current.starts_with("use ") || current.contains(" use ");
        open_use = is_use && !current.trim_end().ends_with(';');
    }
    lines
}

/// Every path beginning with `prefix` in `line` (`crate::a::B`), groups
/// spelled out (`crate::a::{B, c::D}` is `crate::a::B` and
/// `crate::a::c::D`): each as its segments.
fn paths(line: &str, prefix: &str) -> Vec<(usize, Vec<String>)> {
    let mut found = Vec::new();
    let mut start = 0;
    while let Some(at) = line[start..].find(prefix) {
        let at = start + at;
        let before = line[..at].chars().next_back();
        start = at + prefix.len();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        for path in spell_out(&line[at..]) {
            let segments = path
                .split("::")
                .filter(|s| !s.is_empty() && *s != "self")
                .map(String::from)
                .collect();
            found.push((at, segments));
        }
    }
    found
}

/// The paths a path expression at the start of `text` names, its groups
/// (`{...}`, nested) spelled out.
fn spell_out(text: &str) -> Vec<String> {
    let end = text
        .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
        .unwrap_or(text.len());
    let head = &text[..end];
    if !text[end..].starts_with('{') || !head.ends_with("::") {
        return vec![head.to_string()];
    }
    // The group's items, split at its top-level commas.
    let mut depth = 0;
    let mut items = Vec::new();
    let mut item = String::new();
    for c in text[end + 1..].chars() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => break,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(std::mem::take(&mut item));
                continue;
            }
            _ => {}
        }
        item.push(c);
    }
    items.push(item);
    items
        .iter()
        .map(|i| i.trim())
        .filter(|i| !i.is_empty())
        .flat_map(|i| spell_out(i).into_iter().map(move |p| format!("{head}{p}")))
        .collect()
}

fn read_tree(src: &Path) -> Vec<File> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("readable source folder") {
            let path = entry.expect("an entry").path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut paths_found = Vec::new();
    walk(src, &mut paths_found);
    let texts: Vec<(String, String)> = paths_found
        .iter()
        .map(|p| {
            let rel = p
                .strip_prefix(src)
                .expect("under src")
                .to_string_lossy()
                .replace('\\', "/");
            (rel, std::fs::read_to_string(p).expect("readable source"))
        })
        .collect();
    // `crate::` names the library's root, lib.rs (the binary's cli
    // modules name their own siblings through `super::`).
    let modules: BTreeMap<Vec<String>, String> = texts
        .iter()
        .filter(|(rel, _)| rel != "main.rs")
        .map(|(rel, _)| {
            let module = module_of(rel);
            let module = if module == ["lib"] {
                Vec::new()
            } else {
                module
            };
            (module, rel.clone())
        })
        .collect();
    // The longest module a path names, as a file.
    let resolve = |segments: &[String]| -> Option<String> {
        (1..=segments.len())
            .rev()
            .find_map(|n| modules.get(&segments[..n]).cloned())
            .or_else(|| modules.get(&Vec::new()).cloned())
    };
    texts
        .iter()
        .map(|(rel, text)| {
            let mut module = module_of(rel);
            if module == ["lib"] || module == ["main"] {
                module.clear();
            }
            let is_mod = rel.ends_with("mod.rs") || rel == "lib.rs" || rel == "main.rs";
            let lines = code(text);
            let children: BTreeSet<String> = lines
                .iter()
                .filter_map(|(_, l)| {
                    let l = l.trim();
                    let l = l
                        .strip_prefix("pub(crate) ")
                        .or(l.strip_prefix("pub "))
                        .unwrap_or(l);
                    l.strip_prefix("mod ")?.strip_suffix(';').map(String::from)
                })
                .collect();
            let mut uses = Vec::new();
            for (number, line) in &lines {
                for (_, segments) in paths(line, "crate::") {
                    let named: Vec<String> = segments[1..].to_vec();
                    if let Some(target) = resolve(&named) {
                        uses.push((target, segments.join("::"), *number));
                    }
                }
                for (_, segments) in paths(line, "super::") {
                    let ups = segments.iter().take_while(|s| **s == "super").count();
                    // A `mod.rs` is its folder's module: `super` is its parent.
                    let base = module.len().saturating_sub(ups);
                    let mut named: Vec<String> = module[..base].to_vec();
                    named.extend(segments[ups..].iter().cloned());
                    if let Some(target) = resolve(&named) {
                        uses.push((target, segments.join("::"), *number));
                    }
                }
                if is_mod && !line.trim_start().starts_with("mod ") && !line.contains(" mod ") {
                    for child in &children {
                        let needle = format!("{child}::");
                        for (_, segments) in paths(line, &needle) {
                            let mut named = module.clone();
                            named.extend(segments.iter().cloned());
                            if let Some(target) = resolve(&named) {
                                uses.push((target, segments.join("::"), *number));
                            }
                        }
                    }
                }
            }
            uses.retain(|(target, _, _)| target != rel);
            File {
                rel: rel.clone(),
                module,
                uses,
            }
        })
        .collect()
}

/// What breaks the rules: a file on no floor, an upward use, a cycle.
fn violations(files: &[File]) -> Vec<String> {
    let mut found = Vec::new();
    let floor = |rel: &str| -> Option<(u8, &'static str)> {
        let mut module = module_of(rel);
        if module == ["lib"] {
            return Some((8, "the crate's root"));
        }
        if module.is_empty() {
            module.push("lib".into());
        }
        floor_of(&module)
    };
    for file in files {
        let Some((own, own_name)) = floor(&file.rel) else {
            found.push(format!(
                "src/{} is on no floor: give `{}` one in FLOORS (host/tests/architecture.rs)",
                file.rel,
                file.module.first().map_or("lib", String::as_str)
            ));
            continue;
        };
        for (target, text, line) in &file.uses {
            if let Some((theirs, their_name)) = floor(target) {
                if theirs > own {
                    found.push(format!(
                        "src/{}:{line} uses `{text}` (src/{target}, floor {theirs}: {their_name}) \
                         from floor {own} ({own_name}): a module uses only floors below it",
                        file.rel
                    ));
                }
            }
        }
    }
    found.extend(cycles(files));
    found
}

/// The import cycles among `files`, each said with one `use` of each file
/// in it.
fn cycles(files: &[File]) -> Vec<String> {
    let index: BTreeMap<&str, usize> = files
        .iter()
        .enumerate()
        .map(|(i, f)| (f.rel.as_str(), i))
        .collect();
    let edges: Vec<Vec<usize>> = files
        .iter()
        .map(|f| {
            let set: BTreeSet<usize> = f
                .uses
                .iter()
                .filter_map(|(t, _, _)| index.get(t.as_str()).copied())
                .collect();
            set.into_iter().collect()
        })
        .collect();
    // Tarjan's strongly connected components.
    struct Search<'e> {
        edges: &'e [Vec<usize>],
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        stack: Vec<usize>,
        on_stack: Vec<bool>,
        next: usize,
        components: Vec<Vec<usize>>,
    }
    impl Search<'_> {
        fn visit(&mut self, v: usize) {
            self.index[v] = Some(self.next);
            self.low[v] = self.next;
            self.next += 1;
            self.stack.push(v);
            self.on_stack[v] = true;
            for &w in &self.edges[v] {
                match self.index[w] {
                    None => {
                        self.visit(w);
                        self.low[v] = self.low[v].min(self.low[w]);
                    }
                    Some(iw) if self.on_stack[w] => self.low[v] = self.low[v].min(iw),
                    Some(_) => {}
                }
            }
            if Some(self.low[v]) == self.index[v] {
                let mut component = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on_stack[w] = false;
                    component.push(w);
                    if w == v {
                        break;
                    }
                }
                self.components.push(component);
            }
        }
    }
    let n = files.len();
    let mut search = Search {
        edges: &edges,
        index: vec![None; n],
        low: vec![0; n],
        stack: Vec::new(),
        on_stack: vec![false; n],
        next: 0,
        components: Vec::new(),
    };
    for v in 0..n {
        if search.index[v].is_none() {
            search.visit(v);
        }
    }
    search
        .components
        .into_iter()
        .filter(|c| c.len() > 1)
        .map(|component| {
            let members: BTreeSet<usize> = component.iter().copied().collect();
            let uses: Vec<String> = component
                .iter()
                .filter_map(|&v| {
                    let f = &files[v];
                    f.uses
                        .iter()
                        .find(|(t, _, _)| {
                            index.get(t.as_str()).is_some_and(|i| members.contains(i))
                        })
                        .map(|(t, text, line)| {
                            format!("src/{}:{line} uses `{text}` (src/{t})", f.rel)
                        })
                })
                .collect();
            format!(
                "an import cycle of {} files: {}",
                component.len(),
                uses.join("; ")
            )
        })
        .collect()
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn every_file_is_on_a_floor_uses_only_floors_below_and_is_in_no_cycle() {
    let files = read_tree(&src());
    assert!(files.len() > 50, "read {} files", files.len());
    let found = violations(&files);
    assert!(found.is_empty(), "{}", found.join("\n"));
}

#[test]
fn the_check_finds_an_upward_import_and_a_cycle_naming_the_use() {
    let dir = tempfile::tempdir().expect("temp dir");
    let write = |rel: &str, text: &str| {
        let path = dir.path().join(rel);
        std::fs::create_dir_all(path.parent().expect("a folder")).expect("folder");
        std::fs::write(path, text).expect("written");
    };
    write("lib.rs", "mod clock;\nmod scheduler;\nmod mystery;\n");
    write("clock.rs", "use crate::scheduler::State; // upward\n");
    write("scheduler/mod.rs", "mod a;\nmod b;\nmod c;\n");
    write("scheduler/a.rs", "use super::{\n    b::B,\n    c::C,\n};\n");
    write("scheduler/c.rs", "");
    write(
        "scheduler/b.rs",
        "use super::a::A;\n#[cfg(test)]\nmod tests { use crate::system::X; }\n",
    );
    write("mystery.rs", "");
    let found = violations(&read_tree(dir.path()));
    let said = found.join("\n");
    assert!(
        said.contains(
            "src/clock.rs:1 uses `crate::scheduler::State` (src/scheduler/mod.rs, floor 4"
        ),
        "{said}"
    );
    assert!(said.contains("an import cycle of 2 files"), "{said}");
    assert!(
        said.contains("src/scheduler/a.rs:1 uses `super::b::B`"),
        "{said}"
    );
    assert!(
        !said.contains("super::c::C"),
        "a group's other items are not in the cycle"
    );
    assert!(said.contains("src/mystery.rs is on no floor"), "{said}");
    assert!(!said.contains("system"), "test code is not counted: {said}");
    assert_eq!(found.len(), 3, "{said}");
}

#[test]
fn no_source_file_is_over_800_lines() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut long = Vec::new();
    fn walk(dir: &Path, long: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).expect("readable folder") {
            let path = entry.expect("an entry").path();
            let name = path
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or_default();
            if path.is_dir() {
                if !matches!(name, "target" | "node_modules" | ".git") && !name.starts_with('.') {
                    walk(&path, long);
                }
            } else if matches!(
                path.extension().and_then(|e| e.to_str()),
                Some("rs" | "py" | "js")
            ) {
                let lines = std::fs::read_to_string(&path)
                    .map(|t| t.lines().count())
                    .unwrap_or(0);
                if lines > 800 {
                    long.push(format!("{} ({lines} lines)", path.display()));
                }
            }
        }
    }
    walk(&root, &mut long);
    assert!(long.is_empty(), "files over 800 lines: {}", long.join(", "));
}
