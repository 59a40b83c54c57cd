//! `patchvis._native`: the Python extension module (PyO3, abi3) that the `patchvis` package
//! (`python/patchvis/`) wraps.
//!
//! It is thin glue over the library, as the `patchvis` binary is: `bake.rs` maps keyword
//! arguments to `patchvis::bake::BakeSettings` and runs the library's recipe (the same calls
//! as `patchvis bake`, so the same settings give the same bytes), `reader.rs` puts
//! `patchvis::runtime::Pvis` behind a class that owns its bytes. Long calls release the GIL.
//! The Python side adds the report's dataclass, the default progress bar and the docstrings
//! users read; the stubs are `patchvis/_native.pyi`.

mod bake;
mod reader;

use pyo3::prelude::*;

// The library's counting allocator, as in the `patchvis` binary, so that a bake reports each
// stage's peak heap. It forwards to the system allocator and counts Rust allocations only.
#[global_allocator]
static ALLOC: patchvis::heap::CountingAlloc = patchvis::heap::CountingAlloc;

pyo3::create_exception!(
    patchvis,
    FormatError,
    pyo3::exceptions::PyValueError,
    "A .pvis file the reader refuses; the message is the reader's (spec/FORMAT.md)."
);

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("FormatError", m.py().get_type::<FormatError>())?;
    m.add_function(wrap_pyfunction!(bake::bake, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(bake::read_mesh, m)?)?;
    m.add_class::<reader::Reader>()?;
    m.add("MAX_PROBE_PIXELS", patchvis::bake::MAX_PROBE_PIXELS)?;
    Ok(())
}
