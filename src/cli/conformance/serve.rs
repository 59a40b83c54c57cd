//! `patchvis conformance --serve`: the reference reader answering the harness's line protocol
//! on stdin and stdout, the peer `patchvis conformance --reader` expects of any reader
//! (tests/conformance/README.md). It declares `frustum`. A file is parsed again for each
//! request, which costs a checksum over it: meant for the vectors, not for large files.

use super::protocol::{self, VERSION};
use crate::cli::out::{StdoutError, outln};
use patchvis::runtime::{DepthRange, Frustum, Pvis};
use std::io::{self, BufRead};

/// Answers requests until `quit` or the end of stdin.
pub fn run() -> anyhow::Result<()> {
    let mut open: Option<Vec<u8>> = None;
    for line in io::stdin().lock().lines() {
        let line = line?;
        let (verb, rest) = line.split_once(' ').unwrap_or((line.as_str(), ""));
        let reply = match verb {
            "hello" => format!("hello {VERSION} frustum"),
            "open" => match std::fs::read(rest) {
                Err(e) => format!("error {rest}: {e}"),
                Ok(bytes) => match Pvis::parse(&bytes) {
                    Err(e) => {
                        open = None;
                        format!("error {e}")
                    }
                    Ok(_) => {
                        open = Some(bytes);
                        "ok".to_string()
                    }
                },
            },
            "query" | "frustum" => match &open {
                None => "error no file is open".to_string(),
                Some(bytes) => answer(bytes, verb, rest),
            },
            "quit" => break,
            _ => format!("error unknown request `{verb}`"),
        };
        match outln!("{reply}") {
            Err(StdoutError(e)) if e.kind() == io::ErrorKind::BrokenPipe => break,
            result => result?,
        }
    }
    Ok(())
}

/// The reply to `query EYE` or `frustum EYE DEPTH M0,…,M15` on a file that parsed.
fn answer(bytes: &[u8], verb: &str, rest: &str) -> String {
    let pvis = Pvis::parse(bytes).expect("parsed when opened");
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let words: Vec<&str> = rest.split(' ').collect();
    let Some(eye) = words.first().and_then(|w| protocol::parse_point(w)) else {
        return format!("error `{rest}`: expected X,Y,Z first");
    };
    if verb == "frustum" {
        let depth = match words.get(1) {
            Some(&"gl") => DepthRange::NegativeOneToOne,
            Some(&"zero-to-one") => DepthRange::ZeroToOne,
            _ => return format!("error `{rest}`: expected gl or zero-to-one after the eye"),
        };
        let m: Option<Vec<f32>> = words
            .get(2)
            .map(|m| m.split(',').map(protocol::parse_number).collect())
            .unwrap_or_default();
        let Some(m) = m.and_then(|m| <[f32; 16]>::try_from(m).ok()) else {
            return format!("error `{rest}`: expected 16 comma-separated numbers last");
        };
        let frustum = Frustum::from_view_projection(&m, depth);
        let visible = pvis.query_in_frustum(eye, &frustum, &mut scratch);
        return format!("patches {}", protocol::list(visible.patches()));
    }
    let v = pvis.query(eye, &mut scratch);
    format!(
        "inside {} band {} shells {} views {} inner {} patches {}",
        v.inside_sphere,
        v.band,
        protocol::list(v.shells),
        protocol::list(v.leaf),
        protocol::list(v.inner_leaf),
        protocol::list(v.patches()),
    )
}
