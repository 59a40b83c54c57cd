//! `patchvis conformance --reader CMD`: runs another `.pvis` reader against every conformance
//! vector through a line protocol on its stdin and stdout (tests/conformance/README.md,
//! "Testing another reader"), and prints one line per vector: `pass`, or `FAIL` with the first
//! difference and the request that showed it. Exit 0 when every vector passes, 1 otherwise.
//!
//! A valid vector must open, answer every `query` position of its dump as the dump says (a
//! full reader's `query` line, or a far-only reader's `far-query` line), answer a frustum query
//! from each finite position if the reader declares `frustum` (the expectation is the dump's
//! answer culled by the reference [`Frustum`]), and refuse a sample of its truncated prefixes
//! and itself with one byte appended. An invalid vector must be refused (a far-only reader may
//! accept those whose only fault lies inside SHEL's contents). A reader that crashes, hangs or
//! answers out of protocol fails the vector it was on and is started again for the next.

mod peer;
mod protocol;
mod serve;
mod vectors;

use super::args::ConformanceArgs;
use super::out::outln;
use super::view::LookAt;
use anyhow::{Context, Result};
use patchvis::runtime::{DepthRange, Frustum, Pvis};
use peer::{Peer, PeerError};
use protocol::Fields;
use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;
use vectors::{Invalid, Valid, Vectors};

/// Every prefix shorter than this is tried; longer ones are sampled.
const ALL_PREFIXES: usize = 64;
/// Longer prefixes tried per vector, evenly spaced (plus the file less its last byte).
const SAMPLED_PREFIXES: usize = 64;

/// Runs the command: the harness, or with `--serve` the reference reader as its peer.
pub fn run(args: &ConformanceArgs) -> Result<ExitCode> {
    if args.serve {
        serve::run()?;
        return Ok(ExitCode::SUCCESS);
    }
    let command = args.reader.as_deref().context("--reader CMD is required")?;
    let vectors = Vectors::load(&args.vectors)?;
    let scratch = tempfile::tempdir().context("a temporary folder for truncated vectors")?;
    let mut harness = Harness {
        command,
        timeout: Duration::from_secs_f64(args.timeout),
        peer: None,
        features: Features::default(),
        scratch: scratch.path(),
        counts: Counts::default(),
    };
    // A reader that cannot even greet is not worth a line per vector.
    harness
        .peer()
        .map_err(|e| anyhow::anyhow!("--reader {command}: {e}"))?;
    let (mut passed, mut failed) = (0, 0);
    let mut report = |name: &str, verdict: Result<String, String>| {
        match &verdict {
            Ok(_) => passed += 1,
            Err(_) => failed += 1,
        }
        match verdict {
            Ok(what) => outln!("pass {name}: {what}"),
            Err(why) => outln!("FAIL {name}: {why}"),
        }
    };
    for valid in &vectors.valid {
        let verdict = harness.check_valid(valid);
        report(&valid.name, verdict)?;
    }
    for invalid in &vectors.invalid {
        let verdict = harness.check_invalid(invalid);
        report(&invalid.name, verdict)?;
    }
    let c = &harness.counts;
    outln!(
        "{passed} of {} vectors pass ({} queries, {} frustum queries, {} truncated files; \
         reader: {})",
        passed + failed,
        c.queries,
        c.frusta,
        c.truncations,
        harness.features
    )?;
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// What the reader said it does, in its `hello` reply.
#[derive(Clone, Copy, Default)]
struct Features {
    frustum: bool,
    far_only: bool,
}

impl std::fmt::Display for Features {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.far_only { "far-only" } else { "full" })?;
        f.write_str(if self.frustum {
            ", frustum"
        } else {
            ", no frustum"
        })
    }
}

/// Requests made, over all vectors.
#[derive(Default)]
struct Counts {
    queries: u64,
    frusta: u64,
    truncations: u64,
}

/// The reader, started on demand and again after it failed.
struct Harness<'a> {
    command: &'a str,
    timeout: Duration,
    peer: Option<Peer>,
    features: Features,
    scratch: &'a Path,
    counts: Counts,
}

impl Harness<'_> {
    /// The running reader, started and greeted if need be.
    fn peer(&mut self) -> Result<&mut Peer, String> {
        if self.peer.is_none() {
            let mut peer = Peer::start(self.command, self.timeout)
                .map_err(|e| format!("cannot start the reader: {e}"))?;
            let hello = format!("hello {}", protocol::VERSION);
            let reply = peer.ask(&hello).map_err(|e| format!("`{hello}`: {e}"))?;
            let mut words = reply.split_ascii_whitespace();
            if words.next() != Some("hello") || words.next() != Some(&protocol::VERSION.to_string())
            {
                return Err(format!(
                    "`{hello}`: expected `{hello} [FEATURE…]`, got `{reply}`"
                ));
            }
            let features: Vec<&str> = words.collect();
            self.features = Features {
                frustum: features.contains(&"frustum"),
                far_only: features.contains(&"far-only"),
            };
            self.peer = Some(peer);
        }
        Ok(self.peer.as_mut().expect("started above"))
    }

    /// Sends `request`; a reader that fails is dropped, to be started again.
    fn ask(&mut self, request: &str) -> Result<String, String> {
        let reply = self.peer()?.ask(request);
        reply.map_err(|e: PeerError| {
            self.peer = None;
            format!("`{request}`: {e}")
        })
    }

    /// `open PATH`: `Ok(None)` when the reader accepts it, `Ok(Some(why))` when it refuses.
    fn open(&mut self, path: &Path) -> Result<Option<String>, String> {
        let request = format!("open {}", path.display());
        let reply = self.ask(&request)?;
        match reply.split_once(' ').unwrap_or((reply.as_str(), "")) {
            ("ok", "") => Ok(None),
            ("error", why) => Ok(Some(why.to_string())),
            _ => Err(format!(
                "`{request}`: expected `ok` or `error …`, got `{reply}`"
            )),
        }
    }

    fn check_valid(&mut self, vector: &Valid) -> Result<String, String> {
        let bytes =
            std::fs::read(&vector.path).map_err(|e| format!("{}: {e}", vector.path.display()))?;
        if let Some(why) = self.open(&vector.path)? {
            return Err(format!("refused: {why}"));
        }
        for query in &vector.queries {
            let expected = self.expected(query);
            let request = format!("query {}", query.eye);
            let reply = self.ask(&request)?;
            let got = Fields::parse(&reply, &["inside", "patches"])
                .map_err(|e| format!("{request}: {e}"))?;
            if let Some((key, want, got)) = got
                .first_difference(expected)
                .map_err(|e| format!("{request}: {e}"))?
            {
                return Err(format!("{request}: {key} {want} expected, got {got}"));
            }
            self.counts.queries += 1;
        }
        let frusta = if self.features.frustum {
            self.check_frusta(vector, &bytes)?
        } else {
            0
        };
        let truncations = self.check_truncations(&bytes)?;
        Ok(format!(
            "{} queries, {frusta} frustum queries, {truncations} truncated files refused",
            vector.queries.len()
        ))
    }

    /// What this reader should answer to `query`.
    fn expected<'q>(&self, query: &'q vectors::Query) -> &'q Fields {
        if self.features.far_only {
            &query.far_only
        } else {
            &query.full
        }
    }

    /// A frustum query from each finite query position of `vector`: a camera there looking
    /// at a point half a radius beside the centre, 40° wide, near and far planes at 1/100 and
    /// twice that distance, in the OpenGL depth range and the zero-to-one one alternately.
    fn check_frusta(&mut self, vector: &Valid, bytes: &[u8]) -> Result<u64, String> {
        let pvis = Pvis::parse(bytes).map_err(|e| format!("the reference reader: {e}"))?;
        let sampling = pvis.sampling();
        let target = [
            sampling.center[0] + 0.5 * sampling.radius,
            sampling.center[1],
            sampling.center[2],
        ];
        let mut asked = 0;
        for query in &vector.queries {
            let Some(eye) = protocol::parse_point(&query.eye) else {
                continue;
            };
            if !eye.iter().all(|c| c.is_finite()) {
                continue;
            }
            let d = (0..3)
                .map(|k| (f64::from(eye[k]) - f64::from(target[k])).powi(2))
                .sum::<f64>()
                .sqrt();
            let camera = LookAt {
                eye,
                target,
                fov_deg: 40.0,
                aspect: 1.0,
                near: Some((0.01 * d) as f32),
                far: Some((2.0 * d) as f32),
            };
            let Ok(mut m) = camera.view_projection() else {
                continue;
            };
            let (depth, word) = if asked % 2 == 0 {
                (DepthRange::NegativeOneToOne, "gl")
            } else {
                // z' = (z + w) / 2 maps the OpenGL range onto [0, w].
                for col in 0..4 {
                    m[4 * col + 2] = 0.5 * m[4 * col + 2] + 0.5 * m[4 * col + 3];
                }
                (DepthRange::ZeroToOne, "zero-to-one")
            };
            let frustum = Frustum::from_view_projection(&m, depth);
            let want = self.expected(query).get("patches").unwrap_or("[]");
            let mut bits = vec![0u64; (pvis.patch_count() as usize).div_ceil(64)];
            for p in protocol::parse_list(want).unwrap_or_default() {
                if let Some(word) = bits.get_mut(p as usize / 64) {
                    *word |= 1 << (p % 64);
                }
            }
            frustum.cull(&pvis, &mut bits);
            let want = protocol::list(
                (0..pvis.patch_count()).filter(|&p| bits[p as usize / 64] >> (p % 64) & 1 == 1),
            );
            let matrix: Vec<String> = m.iter().map(|x| x.to_string()).collect();
            let request = format!("frustum {} {word} {}", query.eye, matrix.join(","));
            let reply = self.ask(&request)?;
            let got = Fields::parse(&reply, &["patches"]).map_err(|e| format!("{request}: {e}"))?;
            if got.get("patches") != Some(want.as_str()) {
                return Err(format!(
                    "{request}: patches {want} expected, got {}",
                    got.get("patches").unwrap_or_default()
                ));
            }
            asked += 1;
            self.counts.frusta += 1;
        }
        Ok(asked)
    }

    /// Every prefix shorter than [`ALL_PREFIXES`] bytes, [`SAMPLED_PREFIXES`] longer ones and
    /// the file with a byte appended must be refused.
    fn check_truncations(&mut self, bytes: &[u8]) -> Result<u64, String> {
        let n = bytes.len();
        let mut lengths: Vec<usize> = (0..n.min(ALL_PREFIXES)).collect();
        if n > ALL_PREFIXES {
            let span = n - ALL_PREFIXES;
            lengths
                .extend((0..SAMPLED_PREFIXES).map(|i| ALL_PREFIXES + i * span / SAMPLED_PREFIXES));
            lengths.push(n - 1);
        }
        lengths.dedup();
        let mut files: Vec<(String, Vec<u8>)> = lengths
            .iter()
            .map(|&len| (format!("the first {len} bytes"), bytes[..len].to_vec()))
            .collect();
        let mut longer = bytes.to_vec();
        longer.push(0);
        files.push(("the file with a zero byte appended".to_string(), longer));
        for (i, (what, content)) in files.iter().enumerate() {
            let path = self.scratch.join(format!("{i}.pvis"));
            std::fs::write(&path, content).map_err(|e| format!("{}: {e}", path.display()))?;
            let refused = self.open(&path)?;
            let _ = std::fs::remove_file(&path);
            if refused.is_none() {
                return Err(format!("{what} accepted (`open {}`)", path.display()));
            }
            self.counts.truncations += 1;
        }
        Ok(files.len() as u64)
    }

    fn check_invalid(&mut self, vector: &Invalid) -> Result<String, String> {
        match self.open(&vector.path)? {
            Some(why) => Ok(format!("refused ({why})")),
            None if self.features.far_only && vector.far_only_may_accept => {
                Ok("accepted, as a far-only reader may".to_string())
            }
            None => Err("accepted".to_string()),
        }
    }
}
