//! Why a mesh could not be opened: one line naming the file, the position and what was expected.
//!
//! The readers below produce a [`Fault`] (kind, position, message) without knowing the file's
//! name; [`Mesh::open`](super::Mesh::open) attaches the path once, so every message is
//! `file: position: what went wrong, what was expected`.

use std::fmt;
use std::path::{Path, PathBuf};

/// What kind of problem stopped a mesh from opening; stable for tests and callers to match on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum MeshErrorKind {
    /// The operating system could not open or read the file (missing, a directory, no permission).
    Io,
    /// The file type (extension) or the PLY `format` line is not one this reader handles.
    UnsupportedFormat,
    /// The PLY header is malformed: not a PLY file, an unknown keyword or type, a bad count.
    BadHeader,
    /// The body ends before the header's element counts are satisfied.
    Truncated,
    /// A body value could not be parsed as the type the header declares (ASCII files).
    BadValue,
    /// A face refers to a vertex index that is negative or not below the vertex count.
    BadIndex,
    /// A vertex coordinate is NaN or infinite (also after conversion to `f32`).
    NonFinite,
    /// A face has fewer than 3 vertices.
    BadFace,
    /// A required property is missing: `x`, `y`, `z` on vertices or the face index list.
    MissingProperty,
    /// The file has no faces (a point cloud) or its face element is empty.
    NoFaces,
    /// The file has no vertex element or zero vertices.
    NoVertices,
    /// The file is empty (zero bytes).
    Empty,
    /// A count does not fit the `u32` vertex and triangle indices the pipeline uses.
    TooLarge,
    /// The data go on after the elements the header declares: its counts are too small.
    CountMismatch,
    /// Every triangle has zero area: nothing could ever be seen (found by the bake).
    Degenerate,
    /// The coordinates span more than the binary32 camera a `.pvis` stores can represent
    /// (found by the bake).
    OutOfRange,
}

/// Where in the file a problem was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorPosition {
    /// A 1-based line number (the header, or the body of an ASCII file).
    Line(u64),
    /// A 0-based byte offset (the body of a binary file).
    Byte(u64),
}

impl fmt::Display for ErrorPosition {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ErrorPosition::Line(n) => write!(f, "line {n}"),
            ErrorPosition::Byte(n) => write!(f, "byte {n}"),
        }
    }
}

/// Why a mesh could not be opened: names the file, the position and what was expected.
#[derive(Debug)]
pub struct MeshError {
    path: PathBuf,
    kind: MeshErrorKind,
    position: Option<ErrorPosition>,
    message: String,
}

impl MeshError {
    /// What kind of problem this is.
    pub fn kind(&self) -> MeshErrorKind {
        self.kind
    }
    /// Where in the file it was found, when the problem is tied to a place.
    pub fn position(&self) -> Option<ErrorPosition> {
        self.position
    }
    /// The file (or the name given to [`Mesh::from_memory`](super::Mesh::from_memory)).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// An error about the mesh at `path` as a whole (no position), for checks made after it
    /// opened: the bake's.
    pub(crate) fn whole(path: &Path, kind: MeshErrorKind, message: impl Into<String>) -> MeshError {
        Fault::new(kind, None, message).in_file(path)
    }

    pub(crate) fn io(path: &Path, err: &std::io::Error) -> MeshError {
        Fault::new(MeshErrorKind::Io, None, err.to_string()).in_file(path)
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.path.display())?;
        if let Some(position) = self.position {
            write!(f, "{position}: ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for MeshError {}

/// A [`MeshError`] before the file's name is attached; what the format readers return.
#[derive(Debug)]
pub(crate) struct Fault {
    pub(crate) kind: MeshErrorKind,
    pub(crate) position: Option<ErrorPosition>,
    pub(crate) message: String,
}

impl Fault {
    pub(crate) fn new(
        kind: MeshErrorKind,
        position: Option<ErrorPosition>,
        message: impl Into<String>,
    ) -> Fault {
        Fault {
            kind,
            position,
            message: message.into(),
        }
    }
    pub(crate) fn at_line(kind: MeshErrorKind, line: u64, message: impl Into<String>) -> Fault {
        Fault::new(kind, Some(ErrorPosition::Line(line)), message)
    }
    pub(crate) fn at_byte(kind: MeshErrorKind, byte: usize, message: impl Into<String>) -> Fault {
        Fault::new(kind, Some(ErrorPosition::Byte(byte as u64)), message)
    }
    /// Writing the conversion cache failed (disk full, no permission).
    pub(crate) fn cache(err: std::io::Error) -> Fault {
        Fault::new(
            MeshErrorKind::Io,
            None,
            format!("cannot write the conversion cache: {err}"),
        )
    }
    pub(crate) fn in_file(self, path: &Path) -> MeshError {
        MeshError {
            path: path.to_path_buf(),
            kind: self.kind,
            position: self.position,
            message: self.message,
        }
    }
}

/// Quotes at most a line's worth of untrusted text for an error message, so a binary blob or
/// a megabyte-long line cannot flood the terminal.
pub(crate) fn snippet(bytes: &[u8]) -> String {
    const MAX_SNIPPET_CHARS: usize = 60;
    let text = String::from_utf8_lossy(bytes);
    let mut out: String = text
        .chars()
        .take(MAX_SNIPPET_CHARS)
        .flat_map(char::escape_debug)
        .collect();
    if text.chars().count() > MAX_SNIPPET_CHARS {
        out.push('…');
    }
    out
}
