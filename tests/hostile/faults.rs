//! Hostile inputs, over time: see tests/hostile.rs. A mesh that another program truncates
//! while a bake reads it through its memory map. A read of a page that is no longer in the
//! file raises `SIGBUS`; the bake must end with one line naming the file and exit code 1, not
//! die of the signal, and leave no output, temporary or lock file behind.
//!
//! Unix only: `SIGBUS` is a Unix signal (Windows refuses to truncate a mapped file).
#![cfg(unix)]

use std::fs::File;
use std::io::{BufWriter, Write};
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use tempfile::TempDir;

use super::support::{DEADLINE, SMALL, command, wait};
use crate::common::path_str;

/// Writes a wavy height field of `quads` × `quads` squares, two triangles each, as binary
/// little-endian PLY with `float x, y, z` and `list uchar int` faces: the layout the bake maps
/// in place rather than converts, so that truncating the file pulls pages from under its map.
fn write_height_field(path: &Path, quads: u32) {
    let side = quads + 1;
    let mut out = BufWriter::new(File::create(path).unwrap());
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        side * side,
        2 * quads * quads
    )
    .unwrap();
    for j in 0..side {
        for i in 0..side {
            let (x, y) = (i as f32 / quads as f32, j as f32 / quads as f32);
            let z = 0.05 * (x * 40.0).sin() * (y * 31.0).cos();
            for c in [x, y, z] {
                out.write_all(&c.to_le_bytes()).unwrap();
            }
        }
    }
    for j in 0..quads {
        for i in 0..quads {
            let a = (j * side + i) as i32;
            let (b, c, d) = (a + 1, a + side as i32, a + side as i32 + 1);
            for [p, q, r] in [[a, b, d], [a, d, c]] {
                out.write_all(&[3]).unwrap();
                for v in [p, q, r] {
                    out.write_all(&v.to_le_bytes()).unwrap();
                }
            }
        }
    }
    out.flush().unwrap();
}

/// Whether the process `pid` has `file` mapped: its line in `/proc/PID/maps` on Linux. Where
/// there is no `/proc`, true after a short wait, by which time a bake has opened its input.
fn has_mapped(pid: u32, file: &Path) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/maps")) {
        Ok(maps) => maps.lines().any(|l| l.ends_with(path_str(file))),
        Err(_) => {
            std::thread::sleep(Duration::from_millis(300));
            true
        }
    }
}

/// The names in `dir`.
fn names(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

/// Triangles of the first try, about 2M: a 38 MB file that a debug build reads (validates,
/// tiles, copies for the sampler) for seconds, while the truncation comes within a
/// millisecond or so of the map. Should the bake still finish first, it is tried again with a
/// mesh four times larger.
const FIRST_QUADS: u32 = 1000;

#[test]
fn an_input_truncated_during_a_bake_is_one_error_line_not_a_crash() {
    let dir = TempDir::new().unwrap();
    let (inputs, outputs) = (dir.path().join("in"), dir.path().join("out"));
    std::fs::create_dir(&inputs).unwrap();
    // Canonical, as `/proc/PID/maps` names it.
    let mesh = inputs.canonicalize().unwrap().join("wavy.ply");
    let pvis = outputs.join("w.pvis");
    for quads in [FIRST_QUADS, 2 * FIRST_QUADS] {
        let _ = std::fs::remove_dir_all(&outputs);
        std::fs::create_dir(&outputs).unwrap();
        write_height_field(&mesh, quads);
        let log = dir.path().join("stderr");
        let mut args = vec!["bake", path_str(&mesh), "-o", path_str(&pvis)];
        args.extend(SMALL);
        let mut child = command(&args, &[])
            .stdout(Stdio::null())
            .stderr(File::create(&log).unwrap())
            .spawn()
            .expect("run patchvis");
        let deadline = Instant::now() + DEADLINE;
        while !has_mapped(child.id(), &mesh)
            && child.try_wait().unwrap().is_none()
            && Instant::now() < deadline
        {
            std::thread::sleep(Duration::from_millis(1));
        }
        File::options()
            .write(true)
            .open(&mesh)
            .unwrap()
            .set_len(4096)
            .unwrap();
        let status = wait(&mut child, DEADLINE, "patchvis bake of a shrinking mesh");
        let err = std::fs::read_to_string(&log).unwrap();
        if status.success() {
            // It read its last byte of the input before the truncation: a larger mesh.
            assert!(pvis.exists(), "exit 0 without an output: {err}");
            continue;
        }
        assert_eq!(
            status.signal(),
            None,
            "killed by signal {:?} (7 is SIGBUS); stderr: {err:?}",
            status.signal()
        );
        assert_eq!(status.code(), Some(1), "exit status; stderr: {err}");
        assert_eq!(err.lines().count(), 1, "one line expected: {err}");
        let expected = format!(
            "error: {}: the file became shorter while patchvis was reading it",
            mesh.display()
        );
        assert!(
            err.starts_with(&expected),
            "expected {expected:?} in: {err}"
        );
        // No output, no temporary file, no lock file.
        assert_eq!(names(&outputs), Vec::<String>::new());
        return;
    }
    panic!("every bake read its whole input before it was truncated: make the meshes larger");
}
