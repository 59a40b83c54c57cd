//! Hostile inputs: see tests/hostile.rs. What the tool reads and where it prints: stdout that
//! fails or closes, inputs that are not regular files or not what their name says, a mesh
//! edited behind the conversion cache's back, and the messages a user gets for them.
//!
//! Every child runs under a deadline (`support::DEADLINE`): a hang fails the test instead of
//! stalling it.

use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant, SystemTime};

use patchvis::ooc::{Mesh, MeshSource, OpenOptions};
use tempfile::TempDir;

use super::support::{DEADLINE, SMALL, assert_refused, command, run, run_env, wait};
use crate::common::{BUNNY, path_str, stderr, stdout};

/// Starts `patchvis args` with stdout going to `out` and stderr to a pipe.
fn spawn(args: &[&str], out: Stdio) -> Child {
    let mut c = command(args, &[]);
    c.stdout(out).stderr(Stdio::piped());
    c.spawn().expect("spawn patchvis")
}

/// Waits for `child` under [`DEADLINE`]; its status and stderr, read after exit (the runs here
/// write at most a few lines).
fn finish(mut child: Child, what: &str) -> (ExitStatus, String) {
    let status = wait(&mut child, DEADLINE, what);
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        std::io::Read::read_to_string(&mut e, &mut err).expect("read stderr");
    }
    (status, err)
}

/// Bakes the bunny with [`SMALL`] into `dir/b.pvis`.
fn bake_bunny(dir: &Path) -> PathBuf {
    let pvis = dir.join("b.pvis");
    let mut args = vec!["bake", BUNNY, "-o", path_str(&pvis)];
    args.extend(SMALL);
    let out = run(&args);
    assert!(out.status.success(), "bake: {}", stderr(&out));
    pvis
}

/// A command of each kind that prints to stdout, given a baked `pvis` in `dir`.
fn printing_commands(dir: &Path, pvis: &Path) -> Vec<Vec<String>> {
    let p = path_str(pvis).to_string();
    let out = |name: &str| path_str(&dir.join(name)).to_string();
    let own = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let mut bake = own(&["bake", BUNNY, "-o", &out("again.pvis")]);
    bake.extend(own(&SMALL[..6]));
    vec![
        own(&["info", &p]),
        own(&["info", &p, "--json"]),
        own(&["query", &p, "--from", "1,2,3"]),
        own(&["verify", &p]),
        own(&[
            "eval",
            BUNNY,
            &p,
            "--views",
            "2",
            "--resolution",
            "64",
            "--frame-backend",
            "cpu",
            "-q",
        ]),
        bake,
        own(&[
            "gen",
            "--kind",
            "engine",
            "--triangles",
            "2000",
            "-o",
            &out("engine.ply"),
        ]),
    ]
}

/// Issue 21: `info`, `query`, `verify`, `eval`, `bake` and `gen` with stdout on a full
/// device (`> /dev/full`) panicked; now each exits 1 with one line saying stdout cannot be
/// written.
#[test]
fn a_full_stdout_is_one_error_line_and_exit_1() {
    if !Path::new("/dev/full").exists() {
        eprintln!("skipped: no /dev/full on this system");
        return;
    }
    let dir = TempDir::new().unwrap();
    let pvis = bake_bunny(dir.path());
    for args in printing_commands(dir.path(), &pvis) {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let full = File::create("/dev/full").expect("open /dev/full");
        let child = spawn(&args, Stdio::from(full));
        let (status, err) = finish(child, &format!("{args:?}"));
        let out = Output {
            status,
            stdout: Vec::new(),
            stderr: err.into_bytes(),
        };
        assert_refused(
            &out,
            1,
            &["error: cannot write to stdout", "No space left on device"],
        );
    }
}

/// Issue 21: the same commands with the pipe closed by the reader (`| head -c 0`) panicked;
/// now each ends quietly with the exit code it had reached (0 here), nothing on stderr.
#[test]
fn a_closed_pipe_ends_quietly() {
    let dir = TempDir::new().unwrap();
    let pvis = bake_bunny(dir.path());
    for args in printing_commands(dir.path(), &pvis) {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let mut child = spawn(&args, Stdio::piped());
        // The read end closes before the child has written anything.
        drop(child.stdout.take());
        let (status, err) = finish(child, &format!("{args:?}"));
        assert_eq!(status.code(), Some(0), "{args:?} | closed: {err}");
        assert_eq!(err, "", "{args:?} | closed");
    }
    // One line read, then closed: `query --bench` prints several lines.
    let p = path_str(&pvis);
    let mut child = spawn(&["query", p, "--bench", "100"], Stdio::piped());
    let mut first = [0u8; 5];
    std::io::Read::read_exact(child.stdout.as_mut().unwrap(), &mut first).unwrap();
    drop(child.stdout.take());
    let (status, err) = finish(child, "query --bench | head -c 5");
    assert_eq!((status.code(), err.as_str()), (Some(0), ""));
    // `verify` keeps its verdict: an invalid file still exits 1, quietly.
    let bad = dir.path().join("bad.pvis");
    fs::write(&bad, b"PVIS\r\n\x1a\n and then nothing valid").unwrap();
    let mut child = spawn(&["verify", path_str(&bad)], Stdio::piped());
    drop(child.stdout.take());
    let (status, err) = finish(child, "verify bad | closed");
    assert_eq!((status.code(), err.as_str()), (Some(1), ""));
}

/// Makes a FIFO at `path` with `mkfifo`; false (the caller skips) where there is none.
fn mkfifo(path: &Path) -> bool {
    Command::new("mkfifo")
        .arg(path)
        .status()
        .is_ok_and(|s| s.success())
}

/// Issue 21: a FIFO with no writer as input blocked `bake` and `verify` forever (and `info`,
/// `query`, `eval`); now each refuses it at once, exit 1, naming it.
#[test]
fn a_fifo_input_is_refused_at_once() {
    let dir = TempDir::new().unwrap();
    let (mesh_fifo, pvis_fifo) = (dir.path().join("m.ply"), dir.path().join("f.pvis"));
    if !mkfifo(&mesh_fifo) || !mkfifo(&pvis_fifo) {
        eprintln!("skipped: mkfifo is not available");
        return;
    }
    let pvis = bake_bunny(dir.path());
    let (m, f, p) = (path_str(&mesh_fifo), path_str(&pvis_fifo), path_str(&pvis));
    let out = dir.path().join("out.pvis");
    let o = path_str(&out);
    let cases: Vec<Vec<&str>> = vec![
        [&["bake", m, "-o", o][..], &SMALL].concat(),
        vec!["info", f],
        vec!["query", f, "--from", "1,2,3"],
        vec!["eval", BUNNY, f, "--frame-backend", "cpu"],
        vec!["eval", m, p, "--frame-backend", "cpu"],
        vec![
            "gen",
            "--kind",
            "bunny-grid",
            "--triangles",
            "1000",
            "--source",
            m,
            "-o",
            o,
        ],
    ];
    for args in cases {
        let start = Instant::now();
        let got = run(&args);
        assert_refused(&got, 1, &["FIFO", "not a regular file"]);
        assert!(start.elapsed() < Duration::from_secs(10), "{args:?}");
    }
    // `verify` reports its verdict on stdout.
    let got = run(&["verify", f]);
    assert_eq!(got.status.code(), Some(1));
    assert_eq!(
        stdout(&got),
        format!("{f}: cannot read: a FIFO (named pipe), not a regular file\n")
    );
    assert!(!out.exists());
}

/// Issue 21: `verify /dev/zero` or a huge sparse file read the whole file into memory before
/// checking the 8-byte signature; now the signature comes first and the file is mapped, so
/// both are refused at once.
#[test]
fn devices_and_huge_files_are_refused_without_reading_them() {
    let dir = TempDir::new().unwrap();
    let sparse = dir.path().join("sparse.pvis");
    File::create(&sparse).unwrap().set_len(8 << 30).unwrap();
    // The signature, then 8 GiB of holes: mapped, refused on its header.
    let signed = dir.path().join("signed.pvis");
    fs::write(&signed, b"PVIS\r\n\x1a\n").unwrap();
    fs::OpenOptions::new()
        .append(true)
        .open(&signed)
        .unwrap()
        .set_len(8 << 30)
        .unwrap();
    let zero = Path::new("/dev/zero");
    let cases = [
        (
            zero,
            "/dev/zero: cannot read: a character device, not a regular file",
        ),
        (sparse.as_path(), "not a .pvis file: bad signature"),
        (signed.as_path(), "unsupported version 0"),
    ];
    for (path, expected) in cases {
        if !path.exists() {
            continue;
        }
        let p = path_str(path);
        let start = Instant::now();
        let got = run(&["verify", p]);
        assert_eq!(got.status.code(), Some(1), "{p}");
        assert!(stdout(&got).contains(expected), "{p}: {}", stdout(&got));
        for args in [vec!["info", p], vec!["query", p, "--from", "1,2,3"]] {
            let got = run(&args);
            assert_refused(&got, 1, &[expected]);
        }
        assert!(start.elapsed() < Duration::from_secs(10), "{p}");
    }
}

/// An ASCII PLY cube of side 1 at the origin, every coordinate written `0.5`/`1.5`-wide so
/// that an edit can keep the file's length.
fn ascii_cube() -> String {
    let mut s = String::from(
        "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n\
         property float z\nelement face 12\nproperty list uchar int vertex_indices\n\
         end_header\n",
    );
    for i in 0..8 {
        let c = |bit: u32| if i >> bit & 1 == 1 { "1.5" } else { "0.5" };
        s += &format!("{} {} {}\n", c(0), c(1), c(2));
    }
    for f in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ] {
        s += &format!(
            "3 {} {} {}\n3 {} {} {}\n",
            f[0], f[1], f[2], f[0], f[2], f[3]
        );
    }
    s
}

/// Rewrites `path` with `text` of the same length and gives it back its modification time.
fn edit_keeping_size_and_mtime(path: &Path, text: &str) {
    let before = fs::metadata(path).unwrap();
    assert_eq!(before.len(), text.len() as u64);
    let mtime = before.modified().unwrap();
    fs::write(path, text).unwrap();
    File::options()
        .write(true)
        .open(path)
        .unwrap()
        .set_modified(mtime)
        .unwrap();
    let after = fs::metadata(path).unwrap();
    assert_eq!(
        (after.len(), after.modified().unwrap()),
        (before.len(), mtime)
    );
}

/// Issue 21: an ASCII PLY edited with its size and modification time restored was served
/// from the stale conversion cache. The cache key now holds a hash of the whole file.
#[test]
fn an_edit_that_keeps_size_and_mtime_is_not_served_stale() {
    let dir = TempDir::new().unwrap();
    let cache = dir.path().join("cache");
    let mesh = dir.path().join("cube.ply");
    let text = ascii_cube();
    fs::write(&mesh, &text).unwrap();

    // Through the library: converted, then a cache hit, then converted again after the edit.
    let options = OpenOptions {
        cache_dir: Some(cache.clone()),
        ..OpenOptions::default()
    };
    let open = || Mesh::open_with(&mesh, &options).unwrap();
    assert_eq!(open().source(), MeshSource::Converted);
    assert_eq!(open().source(), MeshSource::CacheHit);
    // The last vertex (1.5, 1.5, 1.5) moves to x = 2.5: the bounds grow.
    let at = text.rfind("1.5 1.5 1.5").unwrap();
    let edited = format!("{}2.5{}", &text[..at], &text[at + 3..]);
    edit_keeping_size_and_mtime(&mesh, &edited);
    let reopened = open();
    assert_eq!(reopened.source(), MeshSource::Converted);
    assert_eq!(reopened.bounds().max, [2.5, 1.5, 1.5]);
    assert_eq!(reopened.position(7), [2.5, 1.5, 1.5]);
    assert_eq!(open().source(), MeshSource::CacheHit);

    // Through the binary, with the default cache under XDG_CACHE_HOME: `--mesh-out` holds
    // the vertices the bake read.
    let xdg = dir.path().join("xdg");
    let env = [("XDG_CACHE_HOME", path_str(&xdg))];
    let bake_bounds = |text_now: &str| {
        let out_mesh = dir.path().join("out.ply");
        let pvis = dir.path().join("cube.pvis");
        let mut args = vec!["bake", path_str(&mesh), "-o", path_str(&pvis)];
        args.extend(["--patches", "4", "--mesh-out", path_str(&out_mesh)]);
        args.extend(SMALL);
        let got = run_env(&args, &env);
        assert!(got.status.success(), "{text_now}: {}", stderr(&got));
        Mesh::open_with(
            &out_mesh,
            &OpenOptions {
                cache_dir: None,
                ..OpenOptions::default()
            },
        )
        .unwrap()
        .bounds()
        .max
    };
    fs::write(&mesh, &text).unwrap();
    assert_eq!(bake_bounds("original"), [1.5, 1.5, 1.5]);
    let caches = fs::read_dir(xdg.join("patchvis")).unwrap().count();
    assert_eq!(caches, 1, "the bake converted into the cache");
    edit_keeping_size_and_mtime(&mesh, &edited);
    assert_eq!(bake_bounds("edited"), [2.5, 1.5, 1.5]);
    // The edit replaced the file's cache rather than adding one.
    assert_eq!(fs::read_dir(xdg.join("patchvis")).unwrap().count(), 1);
}

/// Issue 21: a SIGKILL during a text-to-cache conversion left its partial temporary file in
/// the cache for good. The next conversion removes the temporary files of processes that are
/// gone and any nobody wrote for an hour; a live process's is kept.
#[test]
fn a_killed_conversion_leaves_nothing_for_good() {
    let dir = TempDir::new().unwrap();
    let cache = dir.path().join("patchvis");
    fs::create_dir_all(&cache).unwrap();
    // A process that has exited: its pid is free.
    let mut gone = Command::new("true").spawn().expect("run true");
    let dead_pid = gone.id();
    gone.wait().unwrap();
    let dead = cache.join(format!(".pvmesh-tmp-{dead_pid}-AbCdEf"));
    let old = cache.join(".tmpXyZ123");
    let live = cache.join(format!(".pvmesh-tmp-{}-GhIjKl", std::process::id()));
    let unrelated = cache.join("notes.txt");
    for path in [&dead, &old, &live, &unrelated] {
        fs::write(path, b"half a cache").unwrap();
    }
    let two_hours_ago = SystemTime::now() - Duration::from_secs(7200);
    File::options()
        .write(true)
        .open(&old)
        .unwrap()
        .set_modified(two_hours_ago)
        .unwrap();
    let mesh = dir.path().join("cube.ply");
    fs::write(&mesh, ascii_cube()).unwrap();
    let opened = Mesh::open_with(
        &mesh,
        &OpenOptions {
            cache_dir: Some(cache.clone()),
            ..OpenOptions::default()
        },
    )
    .unwrap();
    assert_eq!(opened.source(), MeshSource::Converted);
    let left: Vec<String> = fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    if Path::new("/proc/self").exists() {
        assert!(!dead.exists(), "{left:?}");
    }
    assert!(!old.exists(), "{left:?}");
    assert!(live.exists() && unrelated.exists(), "{left:?}");
    // Nothing of this conversion's is left but its cache.
    let temporaries = left.iter().filter(|n| n.starts_with('.')).count();
    assert_eq!(temporaries, 1 + usize::from(dead.exists()), "{left:?}");
}

/// A GLB holding `mesh` (positions and `u32` indices) under one node moved by `translation`.
fn glb(mesh: &Mesh, translation: [f32; 3]) -> Vec<u8> {
    let mut bin = Vec::new();
    for v in 0..mesh.vertex_count() {
        for c in mesh.position(v) {
            bin.extend(c.to_le_bytes());
        }
    }
    let positions_len = bin.len();
    for t in 0..mesh.triangle_count() {
        for i in mesh.triangle(t) {
            bin.extend(i.to_le_bytes());
        }
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0,"translation":{translation:?}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "buffers":[{{"byteLength":{}}}],
        "bufferViews":[{{"buffer":0,"byteLength":{positions_len}}},
                       {{"buffer":0,"byteOffset":{positions_len},"byteLength":{}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3"}},
                     {{"bufferView":1,"componentType":5125,"count":{},"type":"SCALAR"}}]}}"#,
        bin.len(),
        bin.len() - positions_len,
        mesh.vertex_count(),
        3 * mesh.triangle_count()
    );
    let mut json = json.into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

/// Issue 21: `eval` of a file baked from a `.glb` export, against the model as PLY, said
/// "the file has triangles 0+285, re-tiling the mesh gives 0+285" — two equal values. Now it
/// shows what differs and what to evaluate instead.
#[test]
fn eval_against_another_export_says_what_differs() {
    let dir = TempDir::new().unwrap();
    let export = dir.path().join("bunny.glb");
    // The same triangles, moved by an exporter's node transform.
    fs::write(&export, glb(&crate::common::bunny(), [0.0, 0.0, 0.001])).unwrap();
    let pvis = dir.path().join("glb.pvis");
    let env = [("XDG_CACHE_HOME", path_str(dir.path()))];
    let mut args = vec!["bake", path_str(&export), "-o", path_str(&pvis)];
    args.extend(SMALL);
    let got = run_env(&args, &env);
    assert!(got.status.success(), "{}", stderr(&got));
    let got = run_env(
        &[
            "eval",
            BUNNY,
            path_str(&pvis),
            "--views",
            "2",
            "--frame-backend",
            "cpu",
        ],
        &env,
    );
    assert_refused(
        &got,
        1,
        &[
            "was not baked from",
            " of the file (",
            "the nearest has",
            "bounding sphere at [",
            "evaluate the exact mesh file that was baked",
            "--mesh-out",
        ],
    );
    // The values shown for the file and for the mesh differ.
    let err = stderr(&got);
    let file_part = err.split("): ").next().unwrap();
    let mesh_part = err.split("the nearest has ").nth(1).unwrap();
    let sphere = |s: &str| {
        let after = s.split("bounding sphere at ").nth(1).unwrap();
        let (centre, rest) = after.split_once(" radius ").unwrap();
        let radius = rest.split([',', ';', ')']).next().unwrap();
        (centre.to_owned(), radius.to_owned())
    };
    assert_ne!(sphere(file_part), sphere(mesh_part), "{err}");
}

/// Issue 21: an OBJ with a face pointing past the last vertex on line 23 and another fault
/// on line 28 reported line 28. The first violation in file order is reported now.
#[test]
fn obj_errors_name_the_first_violation() {
    let dir = TempDir::new().unwrap();
    let mut lines: Vec<String> = vec!["# malformed.obj".into()];
    for i in 0..12 {
        lines.push(format!("v {} {} {}", i % 3, i / 3, i % 2));
    }
    for i in 0..9 {
        lines.push(format!("f {} {} {}", i + 1, i + 2, i + 3));
    }
    assert_eq!(lines.len(), 22);
    let cases = [
        // Line 23 names vertex 40 of 13; line 28 is not a number.
        (
            "f 1 2 40",
            "v 1 2 oops",
            "line 23",
            "face refers to vertex 40",
        ),
        // Line 23 names vertex 40, line 28 vertex 90, the largest: still line 23.
        (
            "f 1 2 40",
            "f 1 2 90",
            "line 23",
            "face refers to vertex 40",
        ),
        // Line 23 names vertex 13, defined on line 24: line 28 is the first fault.
        ("f 1 2 13", "v 1 2 oops", "line 28", "expected z (a number)"),
    ];
    for (n, (line23, line28, at, what)) in cases.into_iter().enumerate() {
        let mut obj = lines.clone();
        obj.push(line23.into());
        obj.push("v 0 0 9".into());
        obj.extend(["# a comment".into(), "g part".into(), "s off".into()]);
        obj.push(line28.into());
        obj.push("f 1 2 3".into());
        let path = dir.path().join(format!("malformed{n}.obj"));
        fs::write(&path, obj.join("\n") + "\n").unwrap();
        let out = dir.path().join("m.pvis");
        let mut args = vec!["bake", path_str(&path), "-o", path_str(&out)];
        args.extend(SMALL);
        let got = run_env(&args, &[("XDG_CACHE_HOME", path_str(dir.path()))]);
        assert_refused(&got, 1, &[at, what]);
        assert!(!out.exists());
    }
}

/// Issue 21: random bytes named `.glb` were reported as a JSON parse error; now they are
/// "not a GLB file", with the magic expected and the bytes found.
#[test]
fn random_bytes_named_glb_are_not_a_glb_file() {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("random.glb");
    // Seeded noise, starting with bytes that are neither 'glTF' nor JSON.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut bytes = vec![0x89, b'P', b'N', b'G'];
    bytes.extend((0..4096).map(|_| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state as u8
    }));
    fs::write(&path, &bytes).unwrap();
    let out = dir.path().join("r.pvis");
    let mut args = vec!["bake", path_str(&path), "-o", path_str(&out)];
    args.extend(SMALL);
    let got = run(&args);
    assert_refused(
        &got,
        1,
        &[
            "random.glb",
            "not a GLB file",
            "expected the magic 'glTF'",
            "found 89 50 4e 47",
        ],
    );
    assert!(!stderr(&got).contains("JSON"), "{}", stderr(&got));
    assert!(!out.exists());
}

/// Version-5 files whose SHEL section breaks a rule (issue 22: distances out of order, at or
/// past the sampling distance, below the radius, NaN; a level past 7; lengths that do not sum;
/// no shells or more than 8; two SHEL sections; bad payloads): every reading command refuses
/// each with exit 1 and one line naming the section or the field, never a panic. The files are
/// the conformance vectors `tests/conformance/invalid/17x-v5-*` and `18x-v5-*`.
#[test]
fn broken_sampling_shells_are_refused_in_one_line() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/invalid");
    let mut vectors: Vec<PathBuf> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            name.contains("-v5-") && name.ends_with(".pvis")
        })
        .collect();
    vectors.sort();
    assert!(vectors.len() >= 15, "{} version-5 vectors", vectors.len());
    for vector in &vectors {
        let path = path_str(vector);
        let expected = fs::read_to_string(vector.with_extension("err")).unwrap();
        // Each message names SHEL, whether the fault is in a shell field or a payload.
        assert!(
            expected.contains("SHEL"),
            "{}: {expected}",
            vector.display()
        );
        let words: &[&str] = &["SHEL"];
        for args in [
            vec!["info", path],
            vec!["query", path, "--from", "0,0,1"],
            vec!["verify", path],
        ] {
            let out = run(&args);
            if args[0] == "verify" {
                // verify reports the violation on stdout, exit 1.
                assert_eq!(out.status.code(), Some(1), "{args:?}");
                assert!(stdout(&out).contains(expected.trim_end()), "{args:?}");
                continue;
            }
            assert_refused(&out, 1, words);
            assert!(stderr(&out).contains(expected.trim_end()), "{args:?}");
        }
    }
}
