//! `bake`, `bake_arrays` and `read_mesh`: the library's bake recipe behind Python calls.
//!
//! The options arrive as a dict of the keyword arguments the user gave (`patchvis/_bake.py`
//! lists and documents them); each maps to one field of [`BakeSettings`], and everything not
//! given keeps [`BakeSettings::default`], which is `patchvis bake`'s default. The calls are the
//! binary's (`src/cli/bake.rs`): check the settings, check every output path, open the mesh,
//! [`Recipe::run`], [`Recipe::write`], on the CPU backend. So `bake(path, out, **options)`
//! writes the bytes `patchvis bake path -o out` with the same options writes, and
//! `bake_arrays` the same bytes for the same positions and triangles (the mesh is built in
//! memory by `Mesh::from_memory`; no file is written but the outputs).
//!
//! The GIL is released for the whole bake. Progress reaches a Python callable through
//! [`Callback`], which takes the GIL only to call it, at most every [`PROGRESS_INTERVAL`].

use crate::reader::array2;
use numpy::{PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use patchvis::bake::{
    Backend, BakeError, BakeSettings, Baked, MAX_PROBE_PIXELS, Outputs, PatchOrder, Preset, Probe,
    Recipe, Stages,
};
use patchvis::format::VisibilityEncoding;
use patchvis::ooc::Mesh;
use patchvis::output::{NamedPath, OutputLock, check_outputs};
use patchvis::progress::Progress;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The shortest time between two progress calls within a step: often enough for a bar, rare
/// enough that taking the GIL costs nothing next to the bake.
const PROGRESS_INTERVAL: Duration = Duration::from_millis(100);

/// The name of a mesh built from arrays, in error messages and the report.
const ARRAYS: &str = "<arrays>";

/// `_native.bake(mesh_path, out_path, options, progress)`: see `patchvis.bake`.
#[pyfunction]
#[pyo3(signature = (mesh_path, out_path, options, progress=None))]
pub fn bake(
    py: Python<'_>,
    mesh_path: PathBuf,
    out_path: PathBuf,
    options: &Bound<'_, PyDict>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Py<PyDict>> {
    let job = Job::new(options, out_path, Some(mesh_path.clone()))?;
    let callback = Callback::new(progress);
    let done = py.detach(|| job.run(|recipe| recipe.open(&mesh_path), &callback));
    job.finish(py, done, callback)
}

/// `_native.bake_arrays(vertices, faces, out_path, options, progress)`: see
/// `patchvis.bake_arrays`. `vertices` is `(N, 3)` `float32`, `faces` `(M, 3)` `uint32`, both
/// C-contiguous (the Python side converts and checks the indices' range).
#[pyfunction]
#[pyo3(signature = (vertices, faces, out_path, options, progress=None))]
pub fn bake_arrays(
    py: Python<'_>,
    vertices: PyReadonlyArray2<'_, f32>,
    faces: PyReadonlyArray2<'_, u32>,
    out_path: PathBuf,
    options: &Bound<'_, PyDict>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Py<PyDict>> {
    let vertices = triples(&vertices, "vertices")?;
    let faces = triples(&faces, "faces")?;
    let job = Job::new(options, out_path, None)?;
    let callback = Callback::new(progress);
    let done = py.detach(|| {
        let open = |_: &Recipe| {
            let positions = vertices
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect();
            let triangles = faces.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            Ok(Mesh::from_memory(ARRAYS, positions, triangles)?)
        };
        job.run(open, &callback)
    });
    job.finish(py, done, callback)
}

/// Positions and triangles as numpy arrays.
type MeshArrays<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<u32>>);

/// `_native.read_mesh(path)`: the positions (`(N, 3)` `float32`) and triangles (`(M, 3)`
/// `uint32`) a bake of `path` reads, through the bake's own mesh reader.
#[pyfunction]
pub fn read_mesh<'py>(py: Python<'py>, path: PathBuf) -> PyResult<MeshArrays<'py>> {
    let (positions, triangles) = py
        .detach(|| {
            let mesh = Mesh::open(&path)?;
            let positions: Vec<f32> = (0..mesh.vertex_count())
                .flat_map(|v| mesh.position(v))
                .collect();
            let triangles: Vec<u32> = (0..mesh.triangle_count())
                .flat_map(|t| mesh.triangle(t))
                .collect();
            Ok::<_, patchvis::ooc::MeshError>((positions, triangles))
        })
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok((array2(py, positions, 3)?, array2(py, triangles, 3)?))
}

/// A `(N, 3)` C-contiguous array's values, row after row.
fn triples<'a, T: numpy::Element>(
    array: &'a PyReadonlyArray2<'_, T>,
    name: &str,
) -> PyResult<&'a [T]> {
    if array.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} has shape {:?}, expected (N, 3)",
            array.shape()
        )));
    }
    array
        .as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name} is not C-contiguous")))
}

/// A checked bake: its recipe and outputs.
struct Job {
    recipe: Recipe,
    outputs: Outputs,
    /// The mesh's path, or [`ARRAYS`].
    input: String,
    /// The outputs' locks, held until the job is dropped: another bake naming them is
    /// refused meanwhile, as `patchvis bake` is.
    _lock: OutputLock,
}

/// What a finished bake hands back to Python: the report's parts.
struct Done {
    baked: Baked,
    stages: Stages,
    triangles: u32,
    vertices: u32,
    seconds: f64,
}

impl Job {
    /// The settings of `options`, checked, and every output path checked against the input
    /// and the file system, before any work.
    fn new(
        options: &Bound<'_, PyDict>,
        out_path: PathBuf,
        input: Option<PathBuf>,
    ) -> PyResult<Job> {
        let mut settings = settings(options)?;
        // As the binary: the checkpoints lie beside the output.
        settings.checkpoint = Some(out_path.clone());
        let recipe = settings.check().map_err(|e| PyValueError::new_err(e.0))?;
        let mesh = match options.get_item("mesh_out")? {
            Some(m) if !m.is_none() => Some(m.extract::<PathBuf>()?),
            _ => None,
        };
        let outputs = Outputs {
            pvis: out_path,
            mesh,
        };
        let inputs: Vec<NamedPath> = input
            .iter()
            .map(|p| NamedPath::new("the input mesh", "mesh_path", p))
            .collect();
        let lock = check_outputs(&inputs, &outputs.paths(&recipe))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let input = match &input {
            Some(path) => path.display().to_string(),
            None => ARRAYS.to_string(),
        };
        Ok(Job {
            recipe,
            outputs,
            input,
            _lock: lock,
        })
    }

    /// Opens the mesh with `open` (the `input` stage), runs the recipe and writes the outputs.
    fn run(
        &self,
        open: impl FnOnce(&Recipe) -> Result<Mesh, BakeError>,
        progress: &dyn Progress,
    ) -> Result<Done, BakeError> {
        let start = Instant::now();
        let mut stages = Stages::new();
        let mesh = stages.run("input", || open(&self.recipe))?;
        let baked = self
            .recipe
            .run(&mesh, &Backend::Cpu, progress, &mut stages)?;
        self.recipe
            .write(&baked, &mesh, &self.outputs, &mut stages)?;
        Ok(Done {
            baked,
            stages,
            triangles: mesh.triangle_count(),
            vertices: mesh.vertex_count(),
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The report of a finished bake, or its error; a progress callback's first exception
    /// is raised here, after the bake, and its warnings are issued as Python warnings.
    fn finish(
        &self,
        py: Python<'_>,
        done: Result<Done, BakeError>,
        callback: Callback,
    ) -> PyResult<Py<PyDict>> {
        let (error, warnings) = callback.into_parts();
        if let Some(error) = error {
            return Err(error);
        }
        let done = done.map_err(bake_error)?;
        let report = self.report(py, &done)?;
        report.set_item("warnings", PyList::new(py, &warnings)?)?;
        let warn = py.import("warnings")?.getattr("warn")?;
        for message in &warnings {
            warn.call1((message.as_str(),))?;
        }
        Ok(report.unbind())
    }

    /// The bake's report, as `patchvis.BakeReport` takes it.
    fn report<'py>(&self, py: Python<'py>, done: &Done) -> PyResult<Bound<'py, PyDict>> {
        let b = &done.baked;
        let d = PyDict::new(py);
        d.set_item("input", &self.input)?;
        d.set_item("output", &self.outputs.pvis)?;
        d.set_item("mesh_out", &self.outputs.mesh)?;
        d.set_item("triangles", done.triangles)?;
        d.set_item("vertices", done.vertices)?;
        d.set_item("patches", b.tiling.patches.len())?;
        d.set_item("level", b.plan.level())?;
        d.set_item("views", b.visibility.views())?;
        d.set_item("shells", b.shells.len())?;
        d.set_item("sampled_views", b.sampled_views)?;
        d.set_item("visible_fraction", b.visible_fraction())?;
        d.set_item("bytes", b.bytes.len())?;
        d.set_item("visibility_bytes", b.visibility_bytes)?;
        d.set_item("seconds", done.seconds)?;
        d.set_item("peak_heap_bytes", done.stages.peak_heap_bytes())?;
        let stages = PyList::empty(py);
        for r in done.stages.records() {
            stages.append((r.name, r.seconds, r.peak_heap_bytes))?;
        }
        d.set_item("stages", stages)?;
        Ok(d)
    }
}

/// A bake error as a Python exception: settings and meshes are the caller's values
/// (`ValueError`), files that cannot be written `OSError`, the rest `RuntimeError`.
fn bake_error(e: BakeError) -> PyErr {
    let message = e.to_string();
    match e {
        BakeError::Settings(_) | BakeError::Mesh(_) | BakeError::Tiling(_) => {
            PyValueError::new_err(message)
        }
        BakeError::Write { .. } | BakeError::Remove { .. } | BakeError::TempFile(_) => {
            PyOSError::new_err(message)
        }
        _ => PyRuntimeError::new_err(message),
    }
}

/// The options `patchvis.bake` passes on, each the field of [`BakeSettings`] named after the
/// `patchvis bake` flag it stands for; an unknown key is a `TypeError`.
fn settings(options: &Bound<'_, PyDict>) -> PyResult<BakeSettings> {
    let mut s = BakeSettings::default();
    for (key, value) in options.iter() {
        let key: String = key.extract()?;
        if value.is_none() {
            continue;
        }
        let rows = &mut s.rows;
        match key.as_str() {
            "patches" => s.patches = value.extract()?,
            "conservative" => {
                if value.extract::<bool>()? {
                    rows.preset = Preset::Conservative;
                }
            }
            "memory" => s.memory = patchvis::bake::MemoryBudget::new(value.extract()?),
            "mesh_out" => {} // an output, read by `Job::new`
            "level" => rows.level = Some(value.extract()?),
            "resolution" => rows.resolution = value.extract()?,
            "fov" => rows.fov_deg = value.extract()?,
            "shells" => rows.shells = value.extract()?,
            "shell_min" => rows.shell_min = value.extract()?,
            "shell_level" => rows.shell_level = Some(value.extract()?),
            "shell_resolution" => rows.shell_resolution = Some(value.extract()?),
            "far_shells" => {
                rows.far_shells = match value.extract::<String>() {
                    Ok(text) if text == "none" => Vec::new(),
                    Ok(text) => {
                        return Err(PyValueError::new_err(format!(
                            "far_shells: expected \"none\" or multiples of the sampling distance such as [2, 256], got {text:?}"
                        )));
                    }
                    Err(_) => value.extract()?,
                }
            }
            "view_supersample" => rows.research.view_supersample = Some(value.extract()?),
            "probe" => rows.research.probe = probe(&value)?,
            "apertures" => rows.research.apertures = Some(value.extract()?),
            "patch_order" => {
                rows.patch_order = match value.extract::<String>()?.as_str() {
                    "covisibility" => PatchOrder::Covisibility,
                    "spatial" => PatchOrder::Spatial,
                    other => {
                        return Err(PyValueError::new_err(format!(
                            "patch_order: expected \"covisibility\" or \"spatial\", got {other:?}"
                        )));
                    }
                }
            }
            "encoding" => {
                rows.encoding = match value.extract::<String>()?.as_str() {
                    "tree" => VisibilityEncoding::Tree,
                    "table" => VisibilityEncoding::Table,
                    "raw" => VisibilityEncoding::Raw,
                    other => {
                        return Err(PyValueError::new_err(format!(
                            "encoding: expected \"tree\", \"table\" or \"raw\", got {other:?}"
                        )));
                    }
                }
            }
            other => {
                return Err(PyTypeError::new_err(format!(
                    "bake() got an unexpected keyword argument {other:?}"
                )));
            }
        }
    }
    Ok(s)
}

/// `probe="off"` or pixels (`--probe`).
fn probe(value: &Bound<'_, PyAny>) -> PyResult<Probe> {
    if let Ok(text) = value.extract::<String>() {
        return match text.as_str() {
            "off" => Ok(Probe::Off),
            _ => Err(PyValueError::new_err(format!(
                "probe: expected \"off\" or pixels from 0 to {MAX_PROBE_PIXELS}, got {text:?}"
            ))),
        };
    }
    match value.extract::<u32>() {
        Ok(pixels) if pixels <= MAX_PROBE_PIXELS => Ok(Probe::Pixels(pixels)),
        _ => Err(PyValueError::new_err(format!(
            "probe: expected \"off\" or pixels from 0 to {MAX_PROBE_PIXELS}, got {value}"
        ))),
    }
}

/// A [`Progress`] calling a Python callable, if any, `progress(step, done, total)`: at the start of
/// each step, at most every [`PROGRESS_INTERVAL`] while it runs, and at its end. The
/// library's warnings are kept for `warnings.warn` after the bake; the callable's first
/// exception too, raised after the bake (a bake cannot be stopped half way).
struct Callback {
    /// `None`: warnings only.
    function: Option<Py<PyAny>>,
    step: Mutex<Step>,
    error: Mutex<Option<PyErr>>,
    warnings: Mutex<Vec<String>>,
}

/// The step in progress.
struct Step {
    what: String,
    done: u64,
    total: u64,
    last_call: Instant,
}

impl Callback {
    fn new(function: Option<Py<PyAny>>) -> Callback {
        Callback {
            function,
            step: Mutex::new(Step {
                what: String::new(),
                done: 0,
                total: 0,
                last_call: Instant::now(),
            }),
            error: Mutex::new(None),
            warnings: Mutex::new(Vec::new()),
        }
    }

    /// Calls the function with `step`, unless it raised before. The caller holds the step's
    /// lock, so calls come one at a time and in order.
    fn call(&self, step: &mut Step) {
        step.last_call = Instant::now();
        let Some(function) = &self.function else {
            return;
        };
        let Ok(mut error) = self.error.lock() else {
            return;
        };
        if error.is_some() {
            return;
        }
        Python::attach(|py| {
            let args = (step.what.as_str(), step.done, step.total);
            if let Err(e) = function.call1(py, args) {
                *error = Some(e);
            }
        });
    }

    /// The callable's first exception and the library's warnings.
    fn into_parts(self) -> (Option<PyErr>, Vec<String>) {
        let error = self.error.into_inner().ok().flatten();
        let warnings = self.warnings.into_inner().unwrap_or_default();
        (error, warnings)
    }
}

impl Progress for Callback {
    fn start(&self, what: &str, total: u64) {
        if let Ok(mut step) = self.step.lock() {
            step.what = what.to_string();
            step.done = 0;
            step.total = total;
            self.call(&mut step);
        }
    }

    fn inc(&self, n: u64) {
        if let Ok(mut step) = self.step.lock() {
            step.done = step.done.saturating_add(n);
            if step.last_call.elapsed() >= PROGRESS_INTERVAL {
                self.call(&mut step);
            }
        }
    }

    fn finish(&self) {
        if let Ok(mut step) = self.step.lock() {
            step.done = step.total;
            self.call(&mut step);
        }
    }

    fn warn(&self, message: &str) {
        if let Ok(mut warnings) = self.warnings.lock() {
            warnings.push(message.to_string());
        }
    }
}
