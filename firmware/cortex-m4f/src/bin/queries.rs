//! The `.pvis` reader on a microcontroller (`queries`): a Cortex-M4F (`thumbv7em-none-eabihf`) firmware
//! that parses a `.pvis` held in flash and answers queries with the stateless reader
//! (`Pvis::query`, lock-step decoding, one row of scratch), printing each answer over
//! semihosting in the conformance dump's `query` format. Then it reports the RAM it used:
//! the stack's high-water mark (the scratch row lives on the stack too), found by painting
//! the free stack before the first query and looking for the deepest overwritten word.
//!
//! Built and run under QEMU (`netduinoplus2`, an STM32F405) by `tests/firmware/run.sh`, which
//! compares the answers with the vector's dump. Inputs, fixed at build time:
//! `PATCHVIS_FIRMWARE_FILE` (the `.pvis`) and `PATCHVIS_FIRMWARE_EYES` (one `x,y,z` per line).
#![no_std]
#![no_main]

use core::fmt::Write as _;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hio};
use patchvis::runtime::Pvis;

/// The file, in flash.
static FILE: &[u8] = include_bytes!(env!("PATCHVIS_FIRMWARE_FILE"));
/// The eyes to query, one `x,y,z` per line.
static EYES: &str = include_str!(env!("PATCHVIS_FIRMWARE_EYES"));

/// Scratch words the firmware offers a query: one row of up to 4096 patches.
const SCRATCH_WORDS: usize = 64;
/// Bytes of stack painted below the entry point's frame to find the high-water mark.
const PAINTED: usize = 24 * 1024;
/// The paint.
const PAINT: u32 = 0xDEAD_BEEF;

#[entry]
fn main() -> ! {
    let Ok(mut out) = hio::hstdout() else { fail() };
    let base = paint_stack();
    let ok = run(&mut out).is_ok();
    let used = base - deepest_overwritten(base);
    let _ = writeln!(
        out,
        "ram: stack high-water {used} bytes (scratch row included)"
    );
    if !ok {
        fail()
    }
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Ends the run (QEMU exits) with a failure status.
fn fail() -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Parses the file and answers every eye.
fn run(out: &mut hio::HostStream) -> Result<(), ()> {
    let pvis = match Pvis::parse(FILE) {
        Ok(pvis) => pvis,
        Err(e) => {
            let _ = writeln!(out, "error: {e:?}");
            return Err(());
        }
    };
    let mut scratch = [0u64; SCRATCH_WORDS];
    if pvis.scratch_words() > SCRATCH_WORDS {
        let _ = writeln!(out, "error: {} scratch words needed", pvis.scratch_words());
        return Err(());
    }
    let _ = writeln!(
        out,
        "file: version {} patches {} bytes {} scratch words {}",
        pvis.version(),
        pvis.patch_count(),
        FILE.len(),
        pvis.scratch_words()
    );
    for line in EYES.lines().filter(|l| !l.is_empty()) {
        let mut eye = [0.0f32; 3];
        let mut parts = line.split(',');
        for v in &mut eye {
            *v = parts.next().and_then(|p| p.parse().ok()).ok_or(())?;
        }
        let visible = pvis.query(eye, &mut scratch);
        let [a, b, c] = visible.leaf;
        let _ = write!(out, "query {line} -> inside {}", visible.inside_sphere);
        // A file with sampling shells also says which band and shells answered.
        if pvis.shell_count() > 0 {
            let [o, i] = visible.shells;
            let _ = write!(out, " band {} shells [{o},{i}]", visible.band);
        }
        let _ = write!(out, " views [{a},{b},{c}]");
        if pvis.shell_count() > 0 {
            let [a, b, c] = visible.inner_leaf;
            let _ = write!(out, " inner [{a},{b},{c}]");
        }
        let _ = write!(out, " patches [");
        for (i, p) in visible.patches().enumerate() {
            let _ = write!(out, "{}{p}", if i > 0 { "," } else { "" });
        }
        let _ = writeln!(out, "]");
    }
    Ok(())
}

/// The current stack pointer.
fn stack_pointer() -> usize {
    cortex_m::register::msp::read() as usize
}

/// Paints `PAINTED` bytes of free stack below the current frame; returns the painted top.
#[inline(never)]
fn paint_stack() -> usize {
    // A little below this frame, so painting does not overwrite the painter.
    let top = (stack_pointer() - 256) & !3;
    for at in (top - PAINTED..top).step_by(4) {
        // SAFETY: `at` is in the RAM below the live stack (the stack grows down into it and
        // nothing else uses it: no heap, statics sit at the bottom of RAM), word-aligned.
        unsafe { core::ptr::write_volatile(at as *mut u32, PAINT) };
    }
    top
}

/// The lowest address below `top` whose paint was overwritten.
fn deepest_overwritten(top: usize) -> usize {
    (top - PAINTED..top)
        .step_by(4)
        // SAFETY: the words painted by `paint_stack`, read back.
        .find(|&at| unsafe { core::ptr::read_volatile(at as *const u32) } != PAINT)
        .unwrap_or(top)
}

/// A panic (none is expected: the reader's contracts are checked above) ends the run as a
/// failure.
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    fail()
}
