//! What the integration tests share: the bundled model, running the `patchvis` binary to its end
//! (`tests/hostile/support.rs` also spawns it, with deadlines and signals),
//! one way to bake the bunny with it, and reading what it wrote. Each test crate uses a part
//! of it (`mod common;`).
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use patchvis::ooc::Mesh;
use patchvis::runtime::Pvis;
use patchvis::sampler::VisibilityMatrix;
use patchvis::sphere::view_count;
use tempfile::TempDir;

/// The bundled Stanford bunny (99,785 triangles).
pub const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/bunny.ply");

/// The bunny, opened (memory-mapped) by the library.
pub fn bunny() -> Mesh {
    Mesh::open(Path::new(BUNNY)).expect("the bundled bunny opens")
}

/// Environment under which the Vulkan loader finds no driver, so wgpu finds no adapter.
pub const NO_VULKAN: [(&str, &str); 3] = [
    ("WGPU_BACKEND", "vulkan"),
    ("VK_ICD_FILENAMES", "/nonexistent.json"),
    ("VK_DRIVER_FILES", "/nonexistent.json"),
];

/// Runs the `patchvis` binary with `args`.
pub fn patchvis(args: &[&str]) -> Output {
    patchvis_with_env(args, &[])
}

/// Runs the `patchvis` binary with `args` and the environment variables `env` set.
pub fn patchvis_with_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_patchvis"))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("run patchvis")
}

/// The run's stdout as text.
pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The run's stderr as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The run's stdout as JSON; fails the test (with stderr) if the run failed.
pub fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "failed: {}", stderr(out));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

/// The number at `key` of a JSON object; fails the test if there is none.
pub fn number(v: &serde_json::Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {v}"))
}

/// Says that GPU test `test` is skipped because of `why`, or fails it under `CI=true`, where
/// CI installs Mesa's lavapipe (`.ci/run`) so that the GPU tests run.
pub fn skip_gpu_test(test: &str, why: &str) {
    assert!(
        !std::env::var("CI").is_ok_and(|v| v == "true"),
        "{test}: CI=true but {why}; .ci/run installs Mesa's lavapipe for the GPU tests"
    );
    // Straight to the stream, past the test harness's capture of `eprintln!`, so that a plain
    // `cargo test` shows that the test did not run.
    let _ = writeln!(std::io::stderr(), "GPU test {test} skipped: {why}");
}

/// Bake flags for the bunny in 200 patches at sphere level 2 (66 views), 128 px, quiet: the
/// small file the `eval` tests evaluate.
pub const SMALL_QUIET: [&str; 7] = [
    "--patches",
    "200",
    "--level",
    "2",
    "--resolution",
    "128",
    "-q",
];

/// `patchvis bake BUNNY -o DIR/bunny.pvis FLAGS` in a fresh temporary directory `DIR`:
/// [`Bake::new`], then [`Bake::run`].
pub fn bake(flags: &[&str]) -> Baked {
    Bake::new(flags).run()
}

/// A bake of the bunny to be run, with what it writes besides the `.pvis` file.
pub struct Bake {
    flags: Vec<String>,
    env: Vec<(String, String)>,
    mesh_out: bool,
    stats: bool,
}

/// A finished bake: its temporary directory (removed on drop), the `.pvis` path in it and the
/// binary's output.
pub struct Baked {
    pub dir: TempDir,
    pub pvis: PathBuf,
    pub output: Output,
}

impl Bake {
    /// The bake of the bunny with `flags` after the input and `-o`.
    pub fn new(flags: &[&str]) -> Bake {
        Bake {
            flags: flags.iter().map(|f| f.to_string()).collect(),
            env: Vec::new(),
            mesh_out: false,
            stats: false,
        }
    }

    /// Also passes `flags`.
    pub fn args(mut self, flags: &[&str]) -> Bake {
        self.flags.extend(flags.iter().map(|f| f.to_string()));
        self
    }

    /// Also sets environment variable `key` to `value` for the run.
    pub fn env(mut self, key: &str, value: &str) -> Bake {
        self.env.push((key.into(), value.into()));
        self
    }

    /// Also writes `--mesh-out` to [`Baked::mesh_out`].
    pub fn mesh_out(mut self) -> Bake {
        self.mesh_out = true;
        self
    }

    /// Also writes `--stats` to the file [`Baked::stats`] reads.
    pub fn stats(mut self) -> Bake {
        self.stats = true;
        self
    }

    /// Runs the bake and fails the test (with stderr) if it failed.
    pub fn run(self) -> Baked {
        let flags = format!("{:?}", self.flags);
        let baked = self.attempt();
        assert!(
            baked.output.status.success(),
            "bake {flags} failed: {}",
            stderr(&baked.output)
        );
        baked
    }

    /// Runs the bake, successful or not: the caller checks [`Baked::output`].
    pub fn attempt(self) -> Baked {
        let dir = tempfile::tempdir().expect("temporary directory");
        let pvis = dir.path().join("bunny.pvis");
        let mut args = vec![
            "bake".to_string(),
            BUNNY.to_string(),
            "-o".to_string(),
            path_str(&pvis).to_string(),
        ];
        args.extend(self.flags);
        if self.mesh_out {
            args.extend([
                "--mesh-out".to_string(),
                path_str(&dir.path().join(MESH_OUT)).into(),
            ]);
        }
        if self.stats {
            args.extend([
                "--stats".to_string(),
                path_str(&dir.path().join(STATS)).into(),
            ]);
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let env: Vec<(&str, &str)> = self
            .env
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        let output = patchvis_with_env(&args, &env);
        Baked { dir, pvis, output }
    }
}

/// File names of the optional outputs, in the bake's directory.
const MESH_OUT: &str = "bunny-patches.ply";
const STATS: &str = "stats.json";

impl Baked {
    /// The `.pvis` path as a command-line argument.
    pub fn pvis_arg(&self) -> &str {
        path_str(&self.pvis)
    }

    /// The `.pvis` file's bytes.
    pub fn bytes(&self) -> Vec<u8> {
        std::fs::read(&self.pvis).expect("read the .pvis file")
    }

    /// Where `--mesh-out` wrote ([`Bake::mesh_out`]).
    pub fn mesh_out(&self) -> PathBuf {
        self.dir.path().join(MESH_OUT)
    }

    /// The parsed `--stats` file ([`Bake::stats`]).
    pub fn stats(&self) -> serde_json::Value {
        let bytes = std::fs::read(self.dir.path().join(STATS)).expect("read the stats file");
        serde_json::from_slice(&bytes).expect("stats JSON")
    }

    /// The path of `name` in the bake's directory.
    pub fn file(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
}

/// A path as a command-line argument (the tests' temporary paths are UTF-8).
pub fn path_str(path: &Path) -> &str {
    path.to_str().expect("UTF-8 path")
}

/// The sphere level and every view's row of a `.pvis` file.
pub fn rows(bytes: &[u8]) -> (u32, VisibilityMatrix) {
    let pvis = Pvis::parse(bytes).unwrap_or_else(|e| panic!("not a valid .pvis file: {e:?}"));
    let level = pvis.sampling().level;
    let mut m = VisibilityMatrix::new(view_count(level), pvis.patch_count());
    let mut row = vec![0u64; pvis.row_words()];
    for v in 0..view_count(level) {
        pvis.view_row(v, &mut row);
        m.row_mut(v).copy_from_slice(&row);
    }
    (level, m)
}
