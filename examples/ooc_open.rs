//! Times `Mesh::open_with` on a file and reports the peak heap it used (the library's counting
//! global allocator, `patchvis::heap`), for BENCHMARKS.md; optionally rewrites the mesh as
//! ASCII PLY or OBJ to produce conversion-throughput inputs.
//!
//! `cargo run --release --example ooc_open -- MESH [--cache DIR] [--budget BYTES]
//!  [--write-obj OUT.obj | --write-ascii-ply OUT.ply]`

use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::time::Instant;

use patchvis::heap;
use patchvis::ooc::{Mesh, OpenOptions};

#[global_allocator]
static ALLOC: heap::CountingAlloc = heap::CountingAlloc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let input = PathBuf::from(args.next().ok_or("usage: ooc_open MESH [options]")?);
    let mut options = OpenOptions::default();
    let mut write: Option<(String, PathBuf)> = None;
    while let Some(flag) = args.next() {
        let value = args.next().ok_or("missing value")?;
        match flag.as_str() {
            "--cache" => options.cache_dir = Some(value.into()),
            "--budget" => options.memory_budget = value.parse()?,
            "--write-obj" | "--write-ascii-ply" => write = Some((flag, value.into())),
            _ => return Err(format!("unknown flag {flag}").into()),
        }
    }
    heap::reset_peak();
    let before = heap::current();
    let start = Instant::now();
    let mesh = Mesh::open_with(&input, &options)?;
    let seconds = start.elapsed().as_secs_f64();
    let peak = heap::peak() - before;
    let bytes = std::fs::metadata(&input)?.len();
    println!(
        "{}: {} triangles, {} vertices, {:?}, open {:.3} s, {:.1} MB/s, peak heap {} bytes",
        input.display(),
        mesh.triangle_count(),
        mesh.vertex_count(),
        mesh.source(),
        seconds,
        bytes as f64 / seconds / 1e6,
        peak
    );
    if let Some((kind, out)) = write {
        let mut w = BufWriter::with_capacity(1 << 20, std::fs::File::create(out)?);
        if kind == "--write-ascii-ply" {
            write!(
                w,
                "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
                 property float z\nelement face {}\nproperty list uchar int vertex_indices\n\
                 end_header\n",
                mesh.vertex_count(),
                mesh.triangle_count()
            )?;
        }
        let (v, f, base) = if kind == "--write-obj" {
            ("v ", "f ", 1)
        } else {
            ("", "3 ", 0)
        };
        for i in 0..mesh.vertex_count() {
            let [x, y, z] = mesh.position(i);
            writeln!(w, "{v}{x} {y} {z}")?;
        }
        for t in 0..mesh.triangle_count() {
            let [a, b, c] = mesh.triangle(t).map(|i| i + base);
            writeln!(w, "{f}{a} {b} {c}")?;
        }
        w.flush()?;
    }
    Ok(())
}
