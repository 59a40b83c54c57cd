//! `patchvis verify FILE [--json]`: a full conformance check of one `.pvis` file.
//!
//! `Pvis::parse` already validates every MUST of `spec/FORMAT.md` (the reader answers no
//! query before it has); on top of it this decodes every view's row through the public API and
//! re-checks what a query relies on — patch ranges contiguous from 0 and summing to the
//! triangle count, no bit set past the last patch — so a reader bug shows up here too rather
//! than in a renderer. Exit 0 with a one-line summary, or exit 1 with one line
//! `FILE: <first violation>`. Cost: one parse plus one pass over every row; the file is
//! mapped, and anything that is not a regular file starting with the signature is refused
//! before the rest is read.
//!
//! A row's cost is its patch count, not its bytes: rows that repeat their parents code in
//! a few bits, so a small file can hold a large matrix (790 KB for 65,538 views of 2^20
//! patches, 2^36 bits, minutes to decode). Past [`LONG_BITS`] decoded bits verify says so on
//! stderr and draws its progress on a terminal; `--time-limit` stops it with the verdict
//! "not verified".

use super::args::VerifyArgs;
use super::out::{StdoutError, outln};
use super::progress::Bars;
use patchvis::format::PvisFile;
use patchvis::progress::Progress;
use patchvis::runtime::Pvis;
use serde_json::json;
use std::fmt::Write as _;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Decoded bits past which verify says it will take long and shows its progress: about ten
/// seconds of decoding.
const LONG_BITS: u64 = 1 << 32;

/// What a valid file holds, for the summary line.
struct Summary {
    version: u32,
    patches: u32,
    triangles: u64,
    level: u32,
    views: u32,
    /// Sampling shells besides the sampling sphere (version 5).
    shells: u32,
    bytes: u64,
    /// Visible (view, patch) pairs over all views of the sampling sphere.
    visible_pairs: u64,
}

/// Runs `patchvis verify`; prints the verdict and returns the exit code (0 valid, 1 not).
/// A closed stdout pipe still returns the verdict; a stdout that cannot be written is an
/// error (exit 1, one line on stderr).
pub fn run(args: &VerifyArgs) -> anyhow::Result<ExitCode> {
    let file = args.file.display().to_string();
    // The signature is checked before the rest is read, and the file is mapped, not read.
    let verdict = PvisFile::open(&args.file)
        .map_err(|e| e.to_string())
        .and_then(|bytes| verify(&bytes, &file, args.time_limit));
    let code = match verdict {
        Ok(_) => ExitCode::SUCCESS,
        Err(_) => ExitCode::from(1),
    };
    match report(args, &file, &verdict) {
        Err(e) if e.is_closed_pipe() => Ok(code),
        Err(e) => Err(e.into()),
        Ok(()) => Ok(code),
    }
}

/// Prints the verdict, as text or JSON.
fn report(
    args: &VerifyArgs,
    file: &str,
    verdict: &Result<Summary, String>,
) -> Result<(), StdoutError> {
    if args.json {
        let report = match verdict {
            Ok(s) => json!({
                "file": file, "ok": true, "version": s.version, "patches": s.patches,
                "triangles": s.triangles, "level": s.level, "views": s.views,
                "shells": s.shells, "bytes": s.bytes, "visible_pairs": s.visible_pairs,
            }),
            Err(violation) => json!({"file": file, "ok": false, "error": violation}),
        };
        return outln!("{report}");
    }
    match verdict {
        Ok(s) => outln!(
            "{file}: OK (version {}, {} patches, {} triangles, {} views at level {}, {}\
             {} bytes, {:.1}% of view-patch pairs visible)",
            s.version,
            s.patches,
            s.triangles,
            s.views,
            s.level,
            match s.shells {
                0 => String::new(),
                k => format!("{k} sampling shells, "),
            },
            s.bytes,
            100.0 * s.visible_pairs as f64 / (s.views as f64 * s.patches as f64)
        ),
        Err(violation) => outln!("{file}: {violation}"),
    }
}

/// Checks a whole file (named `file` in the notice of a long check), within `time_limit`
/// seconds if given; `Err` is the first violation, or why it stopped, as one line.
fn verify(bytes: &[u8], file: &str, time_limit: Option<f64>) -> Result<Summary, String> {
    let start = Instant::now();
    let pvis = Pvis::parse(bytes).map_err(|e| e.to_string())?;
    let sampling = pvis.sampling();
    let patches = pvis.patch_count();

    // Re-checks of what parse guarantees, through the public API only. A failure here is a
    // reader bug, and says so.
    let mut next = 0u64;
    for p in 0..patches {
        let info = pvis.patch(p);
        if u64::from(info.first_triangle) != next || info.triangle_count == 0 {
            return Err(reader_bug(format_args!(
                "patch {p} covers triangles {}+{}, expected a non-empty range at {next}",
                info.first_triangle, info.triangle_count
            )));
        }
        next += u64::from(info.triangle_count);
    }
    if next != pvis.triangle_count() {
        return Err(reader_bug(format_args!(
            "patches cover {next} triangles, the file says {}",
            pvis.triangle_count()
        )));
    }
    let words = pvis.row_words();
    let tail_bits = patches % 64;
    let padding = if tail_bits == 0 {
        0
    } else {
        !0u64 << tail_bits
    };
    let mut row = vec![0u64; words];
    let mut visible_pairs = 0u64;
    let rows: u64 = (0..=pvis.shell_count())
        .map(|s| u64::from(pvis.shell(s).views))
        .sum();
    let bits = rows * u64::from(patches);
    let bars = Bars::new(bits > LONG_BITS);
    if bits > LONG_BITS {
        eprintln!(
            "{file}: verifying decodes {bits} bits ({rows} rows of {patches} patches), which \
             takes long; --time-limit bounds it"
        );
    }
    bars.start("rows", rows);
    // `None`: no limit, or one too far off to be a time.
    let deadline = time_limit.and_then(|s| {
        let limit = Duration::try_from_secs_f64(s).ok()?;
        Some((start.checked_add(limit)?, s))
    });
    let mut done = 0u64;
    // Every view of the sampling sphere (shell 0) and of every sampling shell.
    for shell in 0..=pvis.shell_count() {
        for view in 0..pvis.shell(shell).views {
            if let Some((deadline, seconds)) = deadline
                && Instant::now() >= deadline
            {
                bars.finish();
                return Err(format!(
                    "not verified: stopped by --time-limit {seconds} after {done} of {rows} \
                     rows ({bits} bits to decode in all)"
                ));
            }
            pvis.shell_view_row(shell, view, &mut row);
            done += 1;
            bars.inc(1);
            if row.last().is_some_and(|&w| w & padding != 0) {
                let which = match shell {
                    0 => String::new(),
                    s => format!("shell {s} "),
                };
                bars.finish();
                return Err(reader_bug(format_args!(
                    "{which}view {view}: decoded row sets bits past patch {}",
                    patches - 1
                )));
            }
            if shell == 0 {
                visible_pairs += row.iter().map(|w| u64::from(w.count_ones())).sum::<u64>();
            }
        }
    }
    bars.finish();
    Ok(Summary {
        version: pvis.version(),
        patches,
        triangles: pvis.triangle_count(),
        level: sampling.level,
        views: sampling.views,
        shells: pvis.shell_count(),
        bytes: pvis.total_bytes(),
        visible_pairs,
    })
}

fn reader_bug(what: std::fmt::Arguments<'_>) -> String {
    let mut line = String::from("reader bug: accepted a file where ");
    let _ = line.write_fmt(what);
    line
}
