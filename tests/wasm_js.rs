//! The WebAssembly reader's JavaScript (`npm/patchvis.mjs`) prints a refused file's message
//! from its parts (`Error::parts`), so that the `.wasm` carries neither the texts nor a number
//! formatter. These tests keep that copy one with the reader:
//!
//! - the templates and rule texts in `patchvis.mjs` are generated from
//!   `runtime::MESSAGE_TEMPLATES` and `runtime::RULE_TEXTS` (`PATCHVIS_REGENERATE=1 cargo test
//!   --test wasm_js` rewrites them);
//! - run in Node, its `errorMessage` gives exactly `Error::message` for every kind of error
//!   with edge-case and random values, and its `f32Text` exactly `Display` for every exponent
//!   and for random bit patterns.
//!
//! The Node tests need `node` (18 or newer) on the `PATH`; without it they are skipped, except
//! under `CI`, where `.ci/run` installs it.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use patchvis::runtime::{Error, MESSAGE_TEMPLATES, RULE_TEXTS, Rule};

const REGENERATE_VAR: &str = "PATCHVIS_REGENERATE";
const BEGIN: &str = "// BEGIN generated from src/runtime/error.rs by tests/wasm_js.rs\n\
                     // (PATCHVIS_REGENERATE=1 cargo test --test wasm_js); do not edit.\n";
const END: &str = "// END generated\n";

fn module_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("npm/patchvis.mjs")
}

/// The generated block: the templates and rule texts as JavaScript arrays.
fn generated_block() -> String {
    let list = |items: &[&str]| serde_json::to_string_pretty(items).unwrap();
    format!(
        "{BEGIN}const MESSAGE_TEMPLATES = {};\nconst RULE_TEXTS = {};\n{END}",
        list(&MESSAGE_TEMPLATES),
        list(&RULE_TEXTS)
    )
}

#[test]
fn message_tables_in_patchvis_mjs_are_the_readers() {
    let path = module_path();
    let text = std::fs::read_to_string(&path).unwrap();
    let start = text
        .find(BEGIN)
        .expect("patchvis.mjs has the generated block's first line");
    let end = text[start..].find(END).expect("and its last line") + start + END.len();
    let block = generated_block();
    if std::env::var_os(REGENERATE_VAR).is_some_and(|v| v == "1") {
        let updated = format!("{}{block}{}", &text[..start], &text[end..]);
        std::fs::write(&path, updated).unwrap();
        return;
    }
    assert!(
        text[start..end] == block,
        "npm/patchvis.mjs's message tables differ from src/runtime/error.rs: run \
         `{REGENERATE_VAR}=1 cargo test --test wasm_js` and review the diff"
    );
}

/// Runs `script` (an ES module that can import `patchvis.mjs` as `./npm/patchvis.mjs`) in
/// Node with `input` on stdin; returns its stdout lines, or `None` without Node.
fn node(script: &str, input: &str) -> Option<Vec<String>> {
    let child = Command::new("node")
        .args(["--input-type=module", "-e", script])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(child) => child,
        Err(e) if std::env::var_os("CI").is_none() => {
            eprintln!("skipped: cannot run node ({e})");
            return None;
        }
        Err(e) => panic!("node is needed under CI: {e}"),
    };
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "node failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(
        String::from_utf8(out.stdout)
            .unwrap()
            .lines()
            .map(str::to_owned)
            .collect(),
    )
}

/// Reads stdin's lines and prints `f(line)` for each.
fn per_line(body: &str) -> String {
    format!(
        "import {{ errorMessage, f32Text }} from './npm/patchvis.mjs';\n\
         let input = '';\n\
         for await (const chunk of process.stdin) input += chunk;\n\
         const out = [];\n\
         for (const line of input.split('\\n')) {{ if (line) out.push({body}); }}\n\
         console.log(out.join('\\n'));"
    )
}

/// A small deterministic generator (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

#[test]
fn javascript_prints_f32_as_display_does() {
    let mut bits: Vec<u32> = vec![
        0,
        0x8000_0000,
        0x7F80_0000,
        0xFF80_0000,
        0x7FC0_0000,
        0xFFC0_0001,
        1,
        2,
        3,
        0x007F_FFFF,
        0x0080_0000,
        0x0080_0001,
        0x7F7F_FFFF,
        0x3F80_0000,
        0x3DCC_CCCD,
        0x4334_0000,
        0xBF00_0000,
    ];
    let mut rng = Rng(23);
    for biased in 0..=254u32 {
        for fraction in [0, 1, 2, 0x40_0000, 0x7F_FFFF, rng.next() as u32 & 0x7F_FFFF] {
            for sign in [0, 1u32 << 31] {
                bits.push(sign | biased << 23 | fraction);
            }
        }
    }
    bits.extend((0..20_000).map(|_| rng.next() as u32));
    let input: String = bits.iter().map(|b| format!("{b}\n")).collect();
    let Some(got) = node(&per_line("f32Text(Number(line))"), &input) else {
        return;
    };
    assert_eq!(got.len(), bits.len());
    let wrong: Vec<String> = bits
        .iter()
        .zip(&got)
        .filter_map(|(&b, text)| {
            let want = format!("{}", f32::from_bits(b));
            (*text != want).then(|| format!("{b:#010x}: javascript {text}, Display {want}"))
        })
        .collect();
    assert!(
        wrong.is_empty(),
        "{} differ:\n{}",
        wrong.len(),
        wrong[..wrong.len().min(20)].join("\n")
    );
}

#[test]
fn javascript_messages_are_the_readers() {
    let mut rng = Rng(5);
    let tags = [
        *b"CAMR",
        *b"PTCH",
        *b"VISB",
        [0, b'A', 0xFF, 0x20],
        *b"a b~",
        [0x7F; 4],
    ];
    // The first, the last and some between: `RULE_TEXTS` itself is checked above.
    let rules = [
        Rule::HeaderSectionCount,
        Rule::SectionCount,
        Rule::CamrFov,
        Rule::StepCenterRange,
        Rule::RecordAxis,
        Rule::TreeDepth,
        Rule::CodeEnd,
        Rule::ShelRecordLength,
        Rule::ShelCodeEnd,
    ];
    let mut errors = vec![Error::BadMagic];
    for round in 0..40 {
        // Edge values first, then random ones of every size.
        let mut v = || match round {
            0 => 0,
            1 => u64::MAX,
            2 => u64::from(u32::MAX),
            _ => rng.next() >> (rng.next() % 64),
        };
        let (a, b, c, d, e) = (v(), v(), v(), v(), v());
        let tag = tags[round % tags.len()];
        let rule = rules[round % rules.len()];
        errors.extend([
            Error::Truncated { needed: a, have: b },
            Error::UnsupportedVersion { found: a as u32 },
            Error::UnknownFlags { flags: a as u32 },
            Error::LengthMismatch {
                header: a,
                actual: b,
            },
            Error::ChecksumMismatch {
                stored: a as u32,
                computed: b as u32,
            },
            Error::MissingSection { tag },
            Error::DuplicateSection { tag },
            Error::BadSection { tag },
            Error::SectionLength {
                tag,
                length: a,
                expected: b,
            },
            Error::SectionOutOfBounds {
                tag,
                offset: a,
                length: b,
                start: c,
                end: d,
            },
            Error::SectionMisaligned { tag, offset: a },
            Error::LimitExceeded {
                what: rule,
                value: a,
                limit: b,
            },
            Error::Invalid {
                what: rule,
                offset: a,
                value: b,
            },
            Error::InvalidFloat {
                what: rule,
                offset: a,
                bits: e as u32,
            },
            Error::ViewCountMismatch {
                level: a as u32,
                found: b as u32,
                expected: c as u32,
            },
            Error::PatchRange {
                patch: a as u32,
                first: b as u32,
                count: c as u32,
                expected_first: d,
            },
            Error::TriangleCountMismatch { header: a, sum: b },
            Error::UnsupportedEncoding {
                tag: *b"SHEL",
                found: a as u32,
            },
            Error::PaddingBits {
                tag: *b"VISB",
                view: a as u32,
                offset: b,
            },
        ]);
    }
    // Every kind is covered, and its template is the one its parts name.
    let mut kinds: Vec<u32> = errors.iter().map(|e| e.parts().kind).collect();
    kinds.sort_unstable();
    kinds.dedup();
    assert_eq!(
        kinds,
        (0..MESSAGE_TEMPLATES.len() as u32).collect::<Vec<_>>()
    );
    let input: String = errors
        .iter()
        .map(|e| {
            let p = e.parts();
            let values: Vec<String> = p.values.iter().map(u64::to_string).collect();
            format!("{} {}\n", p.kind, values.join(" "))
        })
        .collect();
    let script = per_line(
        "(([kind, ...values]) => errorMessage(Number(kind), values.map(BigInt)))(line.split(' '))",
    );
    let Some(got) = node(&script, &input) else {
        return;
    };
    assert_eq!(got.len(), errors.len());
    for (error, text) in errors.iter().zip(&got) {
        assert_eq!(*text, error.to_string(), "{error:?}");
    }
}
