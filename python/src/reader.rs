//! `_native.Reader`: a `.pvis` file parsed once by the library's reader
//! (`patchvis::runtime::Pvis`), answering queries into numpy arrays.
//!
//! The reader borrows the file's bytes; here the bytes are owned by the object, so the parsed
//! file and its bytes live in one `self_cell` (no `unsafe` code). Single queries use the
//! stateless `Pvis::query`, which is what `patchvis query` answers with. `query_many` uses the
//! expanded reader (`Pvis::expand`: every row decoded once, a query is a point location and a
//! borrowed row), built on its first call and kept, under a lock, with the GIL released while
//! it fills the output.
//!
//! Every method takes its arguments already checked and converted by the Python class
//! (`patchvis/_reader.py`): eyes as `float32`, matrices as 16 column-major `float32`.

use numpy::{Element, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use patchvis::runtime::{DepthRange, Expanded, Frustum, Pvis, Visible};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use self_cell::{MutBorrow, self_cell};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use crate::FormatError;

self_cell!(
    /// A parsed file that owns its bytes.
    struct Parsed {
        owner: Arc<[u8]>,
        #[covariant]
        dependent: Pvis,
    }
);

/// What the expanded reader borrows: the file's bytes and its table.
struct TableOwner {
    bytes: Arc<[u8]>,
    table: MutBorrow<Vec<u64>>,
}

/// The expanded reader, borrowing the bytes and the table for as long as they live.
type ExpandedFile<'a> = Expanded<'a, 'a>;

self_cell!(
    /// A file expanded for `query_many`, with what it borrows.
    struct ExpandedCell {
        owner: TableOwner,
        #[not_covariant]
        dependent: ExpandedFile,
    }
);

/// A `.pvis` file, parsed once; see `patchvis.Reader`.
#[pyclass(module = "patchvis._native", frozen)]
pub struct Reader {
    parsed: Parsed,
    /// Built by the first `query_many`.
    expanded: Mutex<Option<ExpandedCell>>,
}

/// The reader's refusal as a `patchvis.FormatError` with the reader's own message.
fn format_error(e: patchvis::runtime::Error) -> PyErr {
    FormatError::new_err(e.to_string())
}

/// `values` (rows of `columns`) as a `(len / columns, columns)` array.
pub fn array2<T: Element>(
    py: Python<'_>,
    values: Vec<T>,
    columns: usize,
) -> PyResult<Bound<'_, PyArray2<T>>> {
    let rows = values.len() / columns;
    PyArray1::from_vec(py, values).reshape([rows, columns])
}

#[pymethods]
impl Reader {
    /// Parses the file's bytes.
    #[new]
    fn new(py: Python<'_>, data: &[u8]) -> PyResult<Reader> {
        let bytes: Arc<[u8]> = Arc::from(data);
        py.detach(|| Reader::of(bytes))
    }

    /// Reads and parses the file at `path`.
    #[staticmethod]
    fn open(py: Python<'_>, path: PathBuf) -> PyResult<Reader> {
        py.detach(|| {
            let bytes: Arc<[u8]> = Arc::from(std::fs::read(&path)?);
            Reader::of(bytes)
        })
    }

    /// Number of patches.
    #[getter]
    fn patch_count(&self) -> u32 {
        self.pvis().patch_count()
    }

    /// Number of triangles.
    #[getter]
    fn triangle_count(&self) -> u64 {
        self.pvis().triangle_count()
    }

    /// What `patchvis info --json` prints, as a dict.
    #[getter]
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let pvis = self.pvis();
        let s = pvis.sampling();
        let info = PyDict::new(py);
        info.set_item("version", pvis.version())?;
        info.set_item("patches", pvis.patch_count())?;
        info.set_item("triangles", pvis.triangle_count())?;
        info.set_item("level", s.level)?;
        info.set_item("views", s.views)?;
        let camera = PyDict::new(py);
        camera.set_item("center", s.center.to_vec())?;
        camera.set_item("radius", s.radius)?;
        camera.set_item("distance", s.distance)?;
        camera.set_item("fov_deg", s.fov_deg)?;
        camera.set_item("resolution", s.resolution)?;
        info.set_item("camera", camera)?;
        let bytes = PyDict::new(py);
        bytes.set_item("total", pvis.total_bytes())?;
        bytes.set_item("visibility", pvis.visibility_bytes())?;
        bytes.set_item("patch_table", pvis.patch_table_bytes())?;
        bytes.set_item("shells", pvis.shells_bytes())?;
        info.set_item("bytes", bytes)?;
        let sampling = pvis.sampling_shell();
        info.set_item("sampling_shell", sampling)?;
        info.set_item("sampling_reach", pvis.sampling_reach())?;
        let shells = PyList::empty(py);
        for k in (0..=pvis.shell_count()).filter(|&k| k != sampling) {
            let shell = pvis.shell(k);
            let d = PyDict::new(py);
            d.set_item("shell", k)?;
            d.set_item("distance", shell.distance)?;
            d.set_item("level", shell.level)?;
            d.set_item("views", shell.views)?;
            d.set_item("encoding", shell.encoding)?;
            d.set_item("bytes", shell.bytes)?;
            shells.append(d)?;
        }
        info.set_item("shells", shells)?;
        Ok(info)
    }

    /// Each patch's triangles, `(patches, 2)`: first triangle and count.
    #[getter]
    fn patch_ranges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u32>>> {
        let pvis = self.pvis();
        let values = (0..pvis.patch_count())
            .flat_map(|p| {
                let info = pvis.patch(p);
                [info.first_triangle, info.triangle_count]
            })
            .collect();
        array2(py, values, 2)
    }

    /// The visible patches from `eye`, ascending; with `view_proj`, only those in its frustum.
    #[pyo3(signature = (eye, view_proj=None, zero_to_one=false))]
    fn query<'py>(
        &self,
        py: Python<'py>,
        eye: [f32; 3],
        view_proj: Option<[f32; 16]>,
        zero_to_one: bool,
    ) -> Bound<'py, PyArray1<u32>> {
        let patches = self.with_answer(eye, view_proj, zero_to_one, |_, v| v.patches().collect());
        PyArray1::from_vec(py, patches)
    }

    /// The merged triangle ranges of `query`'s answer, `(K, 2)`: first triangle and count.
    #[pyo3(signature = (eye, view_proj=None, zero_to_one=false))]
    fn ranges<'py>(
        &self,
        py: Python<'py>,
        eye: [f32; 3],
        view_proj: Option<[f32; 16]>,
        zero_to_one: bool,
    ) -> PyResult<Bound<'py, PyArray2<u32>>> {
        let values = self.with_answer(eye, view_proj, zero_to_one, |pvis, v| {
            pvis.ranges(v)
                .flat_map(|(first, count)| [first, count])
                .collect()
        });
        array2(py, values, 2)
    }

    /// The whole answer as `patchvis query --json` prints it, as a dict.
    #[pyo3(signature = (eye, view_proj=None, zero_to_one=false))]
    fn answer<'py>(
        &self,
        py: Python<'py>,
        eye: [f32; 3],
        view_proj: Option<[f32; 16]>,
        zero_to_one: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let unculled = view_proj.map(|_| self.with_answer(eye, None, false, |_, v| v.count()));
        let d = PyDict::new(py);
        self.with_answer(eye, view_proj, zero_to_one, |pvis, v| {
            let patches: Vec<u32> = v.patches().collect();
            let ranges: Vec<[u32; 2]> = pvis.ranges(v).map(|(f, c)| [f, c]).collect();
            let triangles: u64 = ranges.iter().map(|r| u64::from(r[1])).sum();
            d.set_item("patches", patches)?;
            d.set_item("ranges", ranges)?;
            d.set_item("inside_sphere", v.inside_sphere)?;
            d.set_item("band", v.band)?;
            d.set_item("shells", v.shells.to_vec())?;
            d.set_item("triangles", triangles)?;
            d.set_item("views", v.leaf.to_vec())?;
            d.set_item("inner_views", v.inner_leaf.to_vec())?;
            if let Some(unculled) = unculled {
                d.set_item("outside_frustum", unculled - v.count())?;
            }
            Ok::<_, PyErr>(())
        })?;
        Ok(d)
    }

    /// The visible sets of many eyes (`(N, 3)` `float32`, C-contiguous), by the expanded
    /// reader, as `uint8`: one byte a patch (0 or 1), or with `packed` the answer's bits, 8
    /// patches a byte, patch `p` at bit `p % 8` of byte `p / 8`; into `out` if given (its
    /// shape checked here), else into a new array. The GIL is released.
    #[pyo3(signature = (eyes, packed=false, out=None))]
    fn query_many<'py>(
        &self,
        py: Python<'py>,
        eyes: PyReadonlyArray2<'py, f32>,
        packed: bool,
        out: Option<Bound<'py, PyArray2<u8>>>,
    ) -> PyResult<Bound<'py, PyArray2<u8>>> {
        if eyes.shape()[1] != 3 {
            return Err(PyValueError::new_err(format!(
                "eyes has shape {:?}, expected (N, 3)",
                eyes.shape()
            )));
        }
        let eyes = eyes
            .as_slice()
            .map_err(|_| PyValueError::new_err("eyes is not C-contiguous and aligned"))?;
        let patches = self.pvis().patch_count() as usize;
        let width = if packed { patches.div_ceil(8) } else { patches };
        let shape = [eyes.len() / 3, width];
        let out = match out {
            Some(out) if out.shape() != shape => {
                return Err(PyValueError::new_err(format!(
                    "out has shape {:?}, expected {shape:?}",
                    out.shape()
                )));
            }
            Some(out) => out,
            None => PyArray2::<u8>::zeros(py, shape, false),
        };
        let mut rows = out
            .try_readwrite()
            .map_err(|_| PyValueError::new_err("out is not writeable or is borrowed elsewhere"))?;
        let rows = rows
            .as_slice_mut()
            .map_err(|_| PyValueError::new_err("out is not C-contiguous"))?;
        py.detach(|| self.fill_many(eyes, rows, width, packed))?;
        Ok(out)
    }

    fn __repr__(&self) -> String {
        let pvis = self.pvis();
        format!(
            "<patchvis.Reader: version {}, {} patches, {} triangles, level {}, {} shells>",
            pvis.version(),
            pvis.patch_count(),
            pvis.triangle_count(),
            pvis.sampling().level,
            pvis.shell_count()
        )
    }
}

/// `query_many` answers fewer eyes than this on the calling thread alone: a thread's start
/// (tens of microseconds) would be a large share of a smaller batch (about 0.1 µs an eye).
const MIN_EYES_PER_THREAD: usize = 4096;

/// Byte `k` of `SPREAD[b]` is bit `k` of `b`: eight patches' bits as eight 0/1 bytes, in one
/// store.
const SPREAD: [u64; 256] = {
    let mut table = [0u64; 256];
    let mut b = 0;
    while b < 256 {
        let mut k = 0;
        while k < 8 {
            table[b] |= ((b as u64 >> k) & 1) << (8 * k);
            k += 1;
        }
        b += 1;
    }
    table
};

/// `bits` (bit `p % 64` of word `p / 64` is patch `p`) as bytes, 8 patches a byte, into
/// `row` (`ceil(patches / 8)` bytes): the words' little-endian bytes.
fn pack(bits: &[u64], row: &mut [u8]) {
    let whole = row.len() / 8;
    let mut chunks = row.chunks_exact_mut(8);
    for (out, word) in (&mut chunks).zip(bits) {
        out.copy_from_slice(&word.to_le_bytes());
    }
    let rest = chunks.into_remainder();
    if let Some(word) = bits.get(whole) {
        let n = rest.len();
        rest.copy_from_slice(&word.to_le_bytes()[..n]);
    }
}

/// `bits` as one byte a patch (0 or 1) into `row` (`patches` bytes), eight patches a store.
fn spread(bits: &[u64], row: &mut [u8]) {
    let eights = |word: u64, out: &mut [u8]| {
        for (j, o) in out.chunks_mut(8).enumerate() {
            let byte = (word >> (8 * j)) as u8;
            o.copy_from_slice(&SPREAD[usize::from(byte)].to_le_bytes()[..o.len()]);
        }
    };
    let whole = row.len() / 64;
    let mut chunks = row.chunks_exact_mut(64);
    for (out, &word) in (&mut chunks).zip(bits) {
        eights(word, out);
    }
    if let Some(&word) = bits.get(whole) {
        eights(word, chunks.into_remainder());
    }
}

impl Reader {
    /// Parses `bytes`.
    fn of(bytes: Arc<[u8]>) -> PyResult<Reader> {
        let parsed = Parsed::try_new(bytes, |b| Pvis::parse(b)).map_err(format_error)?;
        Ok(Reader {
            parsed,
            expanded: Mutex::new(None),
        })
    }

    fn pvis(&self) -> &Pvis<'_> {
        self.parsed.borrow_dependent()
    }

    /// `f(pvis, answer)` for the stateless answer from `eye`, culled by `view_proj`'s
    /// frustum if there is one.
    fn with_answer<T>(
        &self,
        eye: [f32; 3],
        view_proj: Option<[f32; 16]>,
        zero_to_one: bool,
        f: impl FnOnce(&Pvis<'_>, &Visible<'_>) -> T,
    ) -> T {
        let pvis = self.pvis();
        let mut scratch = vec![0u64; pvis.scratch_words()];
        let visible = match view_proj {
            Some(m) => {
                let depth = match zero_to_one {
                    true => DepthRange::ZeroToOne,
                    false => DepthRange::NegativeOneToOne,
                };
                let frustum = Frustum::from_view_projection(&m, depth);
                pvis.query_in_frustum(eye, &frustum, &mut scratch)
            }
            None => pvis.query(eye, &mut scratch),
        };
        f(pvis, &visible)
    }

    /// Answers every eye of `eyes` into its row of `rows` (`width` bytes each).
    fn fill_many(&self, eyes: &[f32], rows: &mut [u8], width: usize, packed: bool) -> PyResult<()> {
        let mut slot = self
            .expanded
            .lock()
            .map_err(|_| PyValueError::new_err("the reader's expanded table was poisoned"))?;
        if slot.is_none() {
            *slot = Some(self.expand()?);
        }
        let Some(cell) = slot.as_mut() else {
            return Ok(());
        };
        let width = width.max(1);
        let words = self.pvis().row_words();
        cell.with_dependent(|_, expanded| {
            let answer = |eyes: &[f32], rows: &mut [u8]| {
                let mut scratch = vec![0u64; words];
                for (eye, row) in eyes.chunks_exact(3).zip(rows.chunks_exact_mut(width)) {
                    let visible = expanded.query_shared([eye[0], eye[1], eye[2]], &mut scratch);
                    match packed {
                        true => pack(visible.bits(), row),
                        false => spread(visible.bits(), row),
                    }
                }
            };
            // A share of the eyes per core, each thread with a scratch row of its own; few
            // eyes stay on this thread.
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
            let per_thread = (eyes.len() / 3).div_ceil(threads).max(MIN_EYES_PER_THREAD);
            if eyes.len() / 3 <= per_thread {
                return answer(eyes, rows);
            }
            let answer = &answer;
            std::thread::scope(|scope| {
                for (eyes, rows) in eyes
                    .chunks(3 * per_thread)
                    .zip(rows.chunks_mut(width * per_thread))
                {
                    scope.spawn(move || answer(eyes, rows));
                }
            });
        });
        Ok(())
    }

    /// The expanded reader of this file.
    fn expand(&self) -> PyResult<ExpandedCell> {
        let bytes = Arc::clone(self.parsed.borrow_owner());
        let words = self.pvis().expanded_bound();
        let owner = TableOwner {
            bytes,
            table: MutBorrow::new(vec![0u64; words]),
        };
        ExpandedCell::try_new(owner, |o| {
            let pvis = Pvis::parse(&o.bytes)?;
            Ok(pvis.expand(o.table.borrow_mut()))
        })
        .map_err(format_error)
    }
}
