//! Times `Mesh::open_with` on a file and reports the peak heap it used (a counting global
//! allocator), for BENCHMARKS.md; optionally rewrites the mesh as ASCII PLY or OBJ to produce
//! conversion-throughput inputs.
//!
//! `cargo run --release --example ooc_open -- MESH [--cache DIR] [--budget BYTES]
//!  [--write-obj OUT.obj | --write-ascii-ply OUT.ply]`

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use patchvis::ooc::{Mesh, OpenOptions};

struct Counting;
static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to `System`; the counters only observe sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let now = CURRENT.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
        PEAK.fetch_max(now, Ordering::Relaxed);
        // SAFETY: the caller's contract.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: the caller's contract.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

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
    let before = CURRENT.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    let start = Instant::now();
    let mesh = Mesh::open_with(&input, &options)?;
    let seconds = start.elapsed().as_secs_f64();
    let peak = PEAK.load(Ordering::Relaxed) - before;
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
