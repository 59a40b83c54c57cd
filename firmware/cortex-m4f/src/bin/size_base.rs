//! Flash probe baseline: `size_probe` without the reader (the file is still embedded and
//! read), so the difference of the two is the reader's code and constants.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use cortex_m_semihosting::debug;

/// The file, in flash.
static FILE: &[u8] = include_bytes!(env!("PATCHVIS_FIRMWARE_FILE"));

#[entry]
fn main() -> ! {
    let scratch = [0u64; 64];
    let _ = black_box([1.0f32, 2.0, 3.0]);
    black_box(black_box(FILE).len() + scratch.len());
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
