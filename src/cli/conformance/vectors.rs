//! The conformance vectors as the harness uses them: each valid file with the eyes of its
//! dump and the answers a full reader and a far-only reader give there, each invalid file, and
//! the invalid files a far-only reader may accept (tests/conformance/README.md).

use super::protocol::Fields;
use anyhow::{Context, Result, bail};
use std::fs;
use std::path::{Path, PathBuf};

/// One `query` position of a dump and what is expected there.
pub struct Query {
    /// The eye as the dump writes it, sent as given.
    pub eye: String,
    /// A full reader's answer (the `query` line).
    pub full: Fields,
    /// A far-only reader's answer: the `far-query` line after it, or the `query` line where
    /// the file has no shells.
    pub far_only: Fields,
}

/// A valid vector.
pub struct Valid {
    /// `valid/NAME.pvis`, for the report.
    pub name: String,
    pub path: PathBuf,
    pub queries: Vec<Query>,
}

/// An invalid vector.
pub struct Invalid {
    /// `invalid/NAME.pvis`, for the report.
    pub name: String,
    pub path: PathBuf,
    /// Whether a far-only reader may accept it (its only fault is inside SHEL's contents).
    pub far_only_may_accept: bool,
}

/// Every vector of a folder holding `valid/`, `invalid/` and `far-only.txt`.
pub struct Vectors {
    pub valid: Vec<Valid>,
    pub invalid: Vec<Invalid>,
}

/// The `.pvis` files of `dir`, by name.
fn files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in fs::read_dir(dir).with_context(|| format!("{}", dir.display()))? {
        let path = entry.with_context(|| format!("{}", dir.display()))?.path();
        if path.extension().is_some_and(|e| e == "pvis") {
            files.push(path);
        }
    }
    files.sort();
    Ok(files)
}

fn name(kind: &str, path: &Path) -> String {
    format!(
        "{kind}/{}",
        path.file_name().unwrap_or_default().to_string_lossy()
    )
}

/// The query positions and answers of a dump.
fn queries(dump_path: &Path) -> Result<Vec<Query>> {
    let dump = fs::read_to_string(dump_path).with_context(|| format!("{}", dump_path.display()))?;
    let mut queries: Vec<Query> = Vec::new();
    for (n, line) in dump.lines().enumerate() {
        let at = || format!("{}:{}", dump_path.display(), n + 1);
        let (far, rest) = if let Some(rest) = line.strip_prefix("far-query ") {
            (true, rest)
        } else if let Some(rest) = line.strip_prefix("query ") {
            (false, rest)
        } else {
            continue;
        };
        let Some((eye, answer)) = rest.split_once(" -> ") else {
            bail!("{}: expected `EYE -> ANSWER`", at());
        };
        let fields = Fields::parse(answer, &["inside", "patches"])
            .map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
        if far {
            match queries.last_mut() {
                Some(q) if q.eye == eye => q.far_only = fields,
                _ => bail!(
                    "{}: a far-query line must follow the query line of its eye",
                    at()
                ),
            }
        } else {
            queries.push(Query {
                eye: eye.to_string(),
                full: fields.clone(),
                far_only: fields,
            });
        }
    }
    Ok(queries)
}

impl Vectors {
    /// Reads the vectors of `dir`.
    pub fn load(dir: &Path) -> Result<Vectors> {
        let list = dir.join("far-only.txt");
        let text = fs::read_to_string(&list).with_context(|| {
            format!(
                "{}: expected the conformance vectors' folder (tests/conformance of the \
                 patchvis sources; --vectors DIR)",
                list.display()
            )
        })?;
        let accepts: Vec<&str> = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .collect();
        let mut valid = Vec::new();
        for path in files(&dir.join("valid"))? {
            valid.push(Valid {
                name: name("valid", &path),
                queries: queries(&path.with_extension("dump"))?,
                path,
            });
        }
        let mut invalid = Vec::new();
        for path in files(&dir.join("invalid"))? {
            let stem = path.file_stem().unwrap_or_default().to_string_lossy();
            invalid.push(Invalid {
                name: name("invalid", &path),
                far_only_may_accept: accepts.contains(&stem.as_ref()),
                path,
            });
        }
        if valid.is_empty() || invalid.is_empty() {
            bail!("{}: no vectors in valid/ or invalid/", dir.display());
        }
        Ok(Vectors { valid, invalid })
    }
}
