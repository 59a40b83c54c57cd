//! ARCHITECTURE.md's mechanical claims, checked against the tree so that the code map cannot
//! drift: every file it names exists, every top-level module of the library is in the code
//! map, the dependency table lists exactly the crates of `Cargo.toml` with the feature that
//! pulls each, and "Where `unsafe` lives" lists exactly the files of `src/` that hold
//! `unsafe` code.

use std::collections::BTreeSet;
use std::fs;
use std::path::Path;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn read(path: &str) -> String {
    fs::read_to_string(Path::new(ROOT).join(path)).unwrap()
}

/// The text of ARCHITECTURE.md's section `heading` (up to the next heading of its level).
fn section(doc: &str, heading: &str) -> String {
    let start = doc
        .find(heading)
        .unwrap_or_else(|| panic!("no section {heading}"));
    let level = heading.chars().take_while(|&c| c == '#').count();
    let rest = &doc[start + heading.len()..];
    let end = rest
        .lines()
        .scan(0, |at, line| {
            let here = *at;
            *at += line.len() + 1;
            Some((here, line))
        })
        .find(|(_, line)| {
            let hashes = line.chars().take_while(|&c| c == '#').count();
            hashes > 0 && hashes <= level && line[hashes..].starts_with(' ')
        })
        .map_or(rest.len(), |(at, _)| at);
    rest[..end].to_string()
}

/// Every file under `dir`, relative to the root, skipping build outputs.
fn files(dir: &Path, out: &mut Vec<String>) {
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with('.') || ["target", "node_modules"].contains(&name.as_str()) {
            continue;
        }
        if path.is_dir() {
            files(&path, out);
        } else {
            let rel = path.strip_prefix(ROOT).unwrap();
            out.push(rel.to_string_lossy().replace('\\', "/"));
        }
    }
}

/// The backticked words of `text`.
fn code_spans(text: &str) -> Vec<&str> {
    text.split('`').skip(1).step_by(2).collect()
}

#[test]
fn every_file_it_names_exists() {
    let doc = read("ARCHITECTURE.md");
    let mut tree = Vec::new();
    files(Path::new(ROOT), &mut tree);
    let extensions = [
        ".rs", ".wgsl", ".sh", ".mjs", ".md", ".toml", ".h", ".c", ".py", ".json",
    ];
    let mut named = 0;
    for span in code_spans(&doc) {
        let path = span.split(':').next().unwrap();
        if path.contains(char::is_whitespace) || !extensions.iter().any(|e| path.ends_with(e)) {
            continue;
        }
        named += 1;
        let found = if let Some((dir, ext)) = path.split_once("/*") {
            tree.iter()
                .any(|f| f.starts_with(&format!("{dir}/")) && f.ends_with(ext))
        } else {
            // A path from the root, or from any folder (`cli/out.rs`, `recipe.rs`).
            tree.iter()
                .any(|f| f == path || f.ends_with(&format!("/{path}")))
        };
        assert!(
            found,
            "ARCHITECTURE.md names `{span}`, which is not in the tree"
        );
    }
    assert!(named > 100, "only {named} file names found");
}

#[test]
fn every_library_module_is_in_the_code_map() {
    let map = section(&read("ARCHITECTURE.md"), "## Code map");
    let lib = read("src/lib.rs");
    let mut modules = 0;
    for line in lib.lines() {
        let line = line.trim();
        let Some(name) = line
            .strip_prefix("pub mod ")
            .or_else(|| line.strip_prefix("pub(crate) mod "))
            .or_else(|| line.strip_prefix("mod "))
            .and_then(|rest| rest.strip_suffix(';'))
        else {
            continue;
        };
        modules += 1;
        let as_path = [format!("src/{name}"), format!("src/{name}.rs")];
        let spans = code_spans(&map);
        assert!(
            spans
                .iter()
                .any(|s| s.trim_end_matches('/') == as_path[0] || *s == as_path[1] || *s == name),
            "module `{name}` (src/lib.rs) is not in ARCHITECTURE.md's code map"
        );
    }
    assert!(modules > 10, "only {modules} modules found in src/lib.rs");
}

/// `[section]` of Cargo.toml as its lines.
fn manifest_section<'m>(manifest: &'m str, name: &str) -> Vec<&'m str> {
    let header = format!("[{name}]");
    manifest
        .lines()
        .skip_while(|l| l.trim() != header)
        .skip(1)
        .take_while(|l| !l.starts_with('['))
        .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
        .collect()
}

#[test]
fn the_dependency_table_matches_the_manifest() {
    let manifest = read("Cargo.toml");
    let dependency = |line: &&str| line.split('=').next().unwrap().trim().to_string();
    let deps: BTreeSet<String> = manifest_section(&manifest, "dependencies")
        .iter()
        .map(dependency)
        .collect();
    let dev: BTreeSet<String> = manifest_section(&manifest, "dev-dependencies")
        .iter()
        .map(dependency)
        .collect();
    // The feature whose list names `dep:NAME`.
    let mut pulled_by: Vec<(String, String)> = Vec::new();
    let mut feature = String::new();
    for line in manifest_section(&manifest, "features") {
        if let Some((name, _)) = line.split_once('=') {
            feature = name.trim().to_string();
        }
        for word in line.split('"').skip(1).step_by(2) {
            if let Some(dep) = word.strip_prefix("dep:") {
                pulled_by.push((dep.to_string(), feature.clone()));
            }
        }
    }
    let table = section(&read("ARCHITECTURE.md"), "## Dependencies");
    let mut listed = BTreeSet::new();
    for row in table.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let name = cells[1].trim_matches('`').to_string();
        let pulls = cells[2];
        let expected = if let Some((_, f)) = pulled_by.iter().find(|(d, _)| *d == name) {
            format!("`{f}`")
        } else if deps.contains(&name) {
            "always".to_string()
        } else {
            assert!(
                dev.contains(&name),
                "`{name}` is in the table but not in Cargo.toml"
            );
            "dev-dependency".to_string()
        };
        assert!(
            pulls.starts_with(&expected),
            "`{name}`: the table says it is pulled by {pulls}; Cargo.toml: {expected}"
        );
        if deps.contains(&name) && dev.contains(&name) {
            assert!(
                pulls.contains("dev-dependency"),
                "`{name}` is also a dev-dependency"
            );
        }
        listed.insert(name);
    }
    for name in deps.iter().chain(&dev) {
        assert!(
            listed.contains(name),
            "`{name}` (Cargo.toml) is not in ARCHITECTURE.md's dependency table"
        );
    }
}

/// Whether a line of Rust holds the `unsafe` keyword outside a comment.
fn has_unsafe(line: &str) -> bool {
    let code = line.split("//").next().unwrap();
    let mut words = code.split(|c: char| !(c.is_alphanumeric() || c == '_'));
    words.any(|w| w == "unsafe")
}

#[test]
fn the_unsafe_list_is_exactly_where_unsafe_is() {
    let mut tree = Vec::new();
    files(&Path::new(ROOT).join("src"), &mut tree);
    let holding: BTreeSet<String> = tree
        .iter()
        .filter(|f| f.ends_with(".rs"))
        .filter(|f| read(f).lines().any(has_unsafe))
        .cloned()
        .collect();
    let list = section(&read("ARCHITECTURE.md"), "## Where `unsafe` lives");
    // The list's items up to the closing paragraph: paths of files, or of a folder whose
    // files are named in its sub-items.
    let items: String = list
        .lines()
        .take_while(|l| !l.starts_with("Every `unsafe` block"))
        .collect::<Vec<_>>()
        .join("\n");
    let named: BTreeSet<String> = code_spans(&items)
        .iter()
        .filter(|s| s.ends_with(".rs"))
        .map(|s| {
            let full = tree
                .iter()
                .find(|f| f == s || f.ends_with(&format!("/{s}")));
            full.unwrap_or_else(|| panic!("`{s}` is listed but not in src/"))
                .clone()
        })
        .collect();
    let forbidding = |f: &String| read(f).contains("#![forbid(unsafe_code)]");
    for file in &holding {
        assert!(
            named.contains(file),
            "{file} holds `unsafe` but is not listed under \"Where `unsafe` lives\""
        );
    }
    for file in &named {
        assert!(
            holding.contains(file) || forbidding(file),
            "{file} is listed under \"Where `unsafe` lives\" but holds no `unsafe`"
        );
    }
}
