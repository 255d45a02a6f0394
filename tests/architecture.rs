//! The crate's shape, checked from its source: the top-level modules form a DAG (no import
//! cycle, direct or through others), inside every module the files form one too (a folder's
//! `mod.rs`, which declares and re-exports the files below it, aside), and no source file is
//! longer than [`MAX_FILE_LINES`].
//!
//! A reference is every path in code (not in comments or strings) that starts with `crate::`,
//! `super::` or `self::`, resolved to the longest module path that names a file of `src/`.
//! `src/main.rs` and `src/cli/` are the shell on top and may use anything.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers from the ground up; a module may use only modules of its own layer or below.
const LAYERS: &[&[&str]] = &[
    &["error", "keyword", "numeric", "team"],
    &["bezier", "geometry"],
    &["chain"],
    &["closest", "eval"],
    &["problem"],
    &["optim"],
    &["adaptive"],
    &["fit", "aero"],
    &["export", "bench"],
];

/// A source file and the module path it defines (`["fit", "curve"]` for `src/fit/curve.rs`).
struct Source {
    path: PathBuf,
    module: Vec<String>,
    text: String,
}

fn sources() -> Vec<Source> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "rs") {
                out.push(p);
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&root, &mut files);
    files.sort();
    files
        .into_iter()
        .map(|path| {
            let rel = path.strip_prefix(&root).unwrap().with_extension("");
            let mut module: Vec<String> = rel.iter().map(|s| s.to_string_lossy().into_owned()).collect();
            if matches!(module.last().map(String::as_str), Some("mod" | "lib" | "main")) {
                module.pop();
            }
            let text = strip_comments(&std::fs::read_to_string(&path).unwrap());
            Source { path, module, text }
        })
        .collect()
}

/// The code of a text: without comments (doc comments included: a doc link to a module
/// above is a pointer for the reader, not a dependency) and without string literals' contents.
fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let code = match line.find("//") {
            Some(k) if !line[..k].contains('"') => &line[..k],
            _ => line,
        };
        let mut in_string = false;
        let mut prev = ' ';
        for c in code.chars() {
            if c == '"' && prev != '\\' {
                in_string = !in_string;
            } else if !in_string {
                out.push(c);
            }
            prev = c;
        }
        out.push('\n');
    }
    out
}

/// Every path a text names from `crate::`, `super::` or `self::`, with `use` groups expanded,
/// as segments (`super` and `self` resolved against `module`, the file's own module path).
fn references(text: &str, module: &[String]) -> Vec<Vec<String>> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut k = 0;
    while k < bytes.len() {
        let starts = ["crate::", "super::", "self::"]
            .iter()
            .find(|p| bytes[k..].starts_with(p.as_bytes()) && (k == 0 || !is_ident(bytes[k - 1])));
        if starts.is_none() {
            k += 1;
            continue;
        }
        let mut prefix: Vec<String> = Vec::new();
        let mut j = k;
        // Resolve the leading `crate`, `super` and `self` segments.
        let mut base: Vec<String> = module.to_vec();
        let mut first = true;
        loop {
            if text[j..].starts_with("crate::") && first {
                base.clear();
                j += 7;
            } else if text[j..].starts_with("super::") {
                base.pop();
                j += 7;
            } else if text[j..].starts_with("self::") {
                j += 6;
            } else {
                break;
            }
            first = false;
        }
        prefix.extend(base);
        j = parse_tree(text, j, &prefix, &mut out);
        k = j.max(k + 1);
    }
    out
}

fn is_ident(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

/// Parse a path tree at `j` (`a::b`, `a::{b, c::d}`, `*`) under `prefix`; push each leaf path.
fn parse_tree(text: &str, mut j: usize, prefix: &[String], out: &mut Vec<Vec<String>>) -> usize {
    let bytes = text.as_bytes();
    while j < bytes.len() && bytes[j].is_ascii_whitespace() {
        j += 1;
    }
    if j < bytes.len() && bytes[j] == b'{' {
        j += 1;
        loop {
            j = parse_tree(text, j, prefix, out);
            while j < bytes.len() && bytes[j] != b',' && bytes[j] != b'}' {
                j += 1;
            }
            if j >= bytes.len() || bytes[j] == b'}' {
                return j + 1;
            }
            j += 1;
        }
    }
    let start = j;
    while j < bytes.len() && is_ident(bytes[j]) {
        j += 1;
    }
    if start == j {
        out.push(prefix.to_vec());
        return j;
    }
    let mut path = prefix.to_vec();
    let name = &text[start..j];
    if name != "self" {
        path.push(name.to_string());
    }
    if text[j..].starts_with("::") {
        return parse_tree(text, j + 2, &path, out);
    }
    out.push(path);
    j
}

/// The dependency graph of `nodes` (module paths), each file's references resolved to the
/// longest node that prefixes them, self-references left out.
/// Each edge keeps one of the references that make it, `file: path`, for the messages.
type Graph = BTreeMap<Vec<String>, BTreeMap<Vec<String>, String>>;

fn graph(files: &[Source], node_of: impl Fn(&[String]) -> Option<Vec<String>>) -> Graph {
    let mut g = Graph::new();
    for f in files {
        let Some(from) = node_of(&f.module) else { continue };
        let targets = g.entry(from.clone()).or_default();
        for r in references(&f.text, &f.module) {
            if let Some(to) = node_of(&r) {
                if to != from {
                    targets
                        .entry(to)
                        .or_insert_with(|| format!("{}: {}", f.path.display(), r.join("::")));
                }
            }
        }
    }
    g
}

/// The edges of `g` inside `component`, with their evidence, one a line.
fn explain(g: &Graph, component: &[Vec<String>]) -> String {
    let mut out = String::new();
    for from in component {
        for (to, why) in g.get(from).into_iter().flatten() {
            if component.contains(to) {
                out.push_str(&format!("\n  {} -> {}   ({why})", from.join("/"), to.join("/")));
            }
        }
    }
    out
}

/// The cycles of `g`: its strongly connected components of more than one node.
fn cycles(g: &Graph) -> Vec<Vec<Vec<String>>> {
    // Reachability by depth-first search from every node (the graphs are small).
    let reach = |from: &Vec<String>| -> BTreeSet<Vec<String>> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(n) = stack.pop() {
            for m in g.get(&n).into_iter().flat_map(|t| t.keys()) {
                if seen.insert(m.clone()) {
                    stack.push(m.clone());
                }
            }
        }
        seen
    };
    let reaches: BTreeMap<_, _> = g.keys().map(|n| (n.clone(), reach(n))).collect();
    let mut done = BTreeSet::new();
    let mut out = Vec::new();
    for n in g.keys() {
        if done.contains(n) || !reaches[n].contains(n) {
            continue;
        }
        let component: Vec<Vec<String>> = g
            .keys()
            .filter(|m| reaches[n].contains(*m) && reaches[*m].contains(n))
            .cloned()
            .collect();
        done.extend(component.iter().cloned());
        out.push(component);
    }
    out
}

fn is_shell(module: &[String]) -> bool {
    module.is_empty() || module[0] == "cli" || module[0] == "main"
}

#[test]
fn the_top_level_modules_form_layers_without_cycles() {
    let files = sources();
    let g = graph(&files, |m| (!is_shell(m)).then(|| m[..1].to_vec()));
    let layer = |m: &str| LAYERS.iter().position(|l| l.contains(&m));
    for node in g.keys() {
        assert!(
            layer(&node[0]).is_some(),
            "src/{}: a top-level module no layer names",
            node[0]
        );
    }
    let cycles: String = cycles(&g).iter().map(|c| explain(&g, c)).collect();
    assert!(
        cycles.is_empty(),
        "import cycles between top-level modules:{cycles}"
    );
    let mut upward = Vec::new();
    for (from, tos) in &g {
        for (to, why) in tos {
            if layer(&to[0]) > layer(&from[0]) {
                upward.push(format!("{} -> {} ({why})", from[0], to[0]));
            }
        }
    }
    assert!(
        upward.is_empty(),
        "modules that use a layer above their own: {upward:?}"
    );
}

#[test]
fn the_files_of_every_module_form_a_dag() {
    let files = sources();
    let modules: BTreeSet<Vec<String>> = files.iter().map(|f| f.module.clone()).collect();
    // A file's node is itself; a reference's node is the longest file module prefixing it.
    let node_of = |path: &[String]| -> Option<Vec<String>> {
        if is_shell(path) {
            return None;
        }
        (1..=path.len())
            .rev()
            .map(|n| path[..n].to_vec())
            .find(|p| modules.contains(p))
    };
    let g = graph(&files, node_of);
    // Edges inside one top-level module, less those between a folder's root (`mod.rs`, which
    // declares and re-exports its files) and the files below it; the top-level test covers
    // the edges between modules.
    let mut inside = Graph::new();
    for (from, tos) in &g {
        let entry = inside.entry(from.clone()).or_default();
        for (to, why) in tos {
            let same_module = from[0] == to[0];
            let nested = to.starts_with(from) || from.starts_with(to);
            if same_module && !nested {
                entry.insert(to.clone(), why.clone());
            }
        }
    }
    assert!(files.len() > 50, "the sources were not found");
    let cycles: String = cycles(&inside).iter().map(|c| explain(&inside, c)).collect();
    assert!(
        cycles.is_empty(),
        "files of one module that import each other:{cycles}"
    );
}

#[test]
fn the_reference_parser_reads_groups_and_relative_paths() {
    let module = vec!["fit".to_string(), "curve".to_string()];
    let text = "use crate::optim::{lsq::{lsq, Start}, evo};\nuse super::population::Frame;\nlet x = crate::chain::samples(b, 3);";
    let refs = references(text, &module);
    let want: Vec<Vec<String>> = [
        vec!["optim", "lsq", "lsq"],
        vec!["optim", "lsq", "Start"],
        vec!["optim", "evo"],
        vec!["fit", "population", "Frame"],
        vec!["chain", "samples"],
    ]
    .iter()
    .map(|v| v.iter().map(|s| s.to_string()).collect())
    .collect();
    assert_eq!(refs, want);
    let edge = |a: &str, b: &str| {
        (
            vec![a.to_string()],
            BTreeMap::from([(vec![b.to_string()], String::new())]),
        )
    };
    let cyclic: Graph = [edge("a", "b"), edge("b", "c"), edge("c", "a"), edge("d", "a")].into();
    assert_eq!(
        cycles(&cyclic),
        vec![vec![
            vec!["a".to_string()],
            vec!["b".to_string()],
            vec!["c".to_string()]
        ]]
    );
}

/// The most lines a source file may have: past it a file holds several concepts, and one of
/// them wants a file of its own.
const MAX_FILE_LINES: usize = 1200;

#[test]
fn no_source_file_is_longer_than_the_limit() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut long = String::new();
    let mut shaders: Vec<PathBuf> = std::fs::read_dir(root.join("shaders"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    shaders.sort();
    let files = sources().into_iter().map(|s| s.path).chain(shaders);
    let mut read = 0;
    for path in files {
        let lines = std::fs::read_to_string(&path).unwrap().lines().count();
        read += 1;
        if lines > MAX_FILE_LINES {
            long.push_str(&format!("\n  {}: {lines} lines", path.display()));
        }
    }
    assert!(read > 50, "the sources were not found");
    assert!(
        long.is_empty(),
        "files over {MAX_FILE_LINES} lines (split them by concept):{long}"
    );
}
