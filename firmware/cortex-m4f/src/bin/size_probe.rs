//! Flash probe: the reader's code alone. Parses the embedded file and answers one query whose
//! eye the compiler cannot see (`black_box`), and nothing else; `size_base` is the same
//! program without the reader. `tests/firmware/run.sh` reports the difference of their
//! `.text + .rodata` as the reader's flash.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use cortex_m_semihosting::debug;
use patchvis::runtime::Pvis;

/// The file, in flash.
static FILE: &[u8] = include_bytes!(env!("PATCHVIS_FIRMWARE_FILE"));

#[entry]
fn main() -> ! {
    let mut scratch = [0u64; 64];
    let eye = black_box([1.0f32, 2.0, 3.0]);
    let visible = match Pvis::parse(black_box(FILE)) {
        Ok(pvis) if pvis.scratch_words() <= scratch.len() => pvis.query(eye, &mut scratch).count(),
        _ => 0,
    };
    black_box(visible);
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
