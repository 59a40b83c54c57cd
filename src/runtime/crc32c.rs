//! CRC-32C (Castagnoli), the checksum in the `.pvis` trailer (spec § Trailer).
//!
//! Reflected polynomial 0x82F63B78, initial value and final xor 0xFFFFFFFF; the check value of
//! `"123456789"` is 0xE3069283. Table-driven (Sarwate 1988), the table built at compile time.
//! The bake (feature `bake`), which checksums every file it writes and its large sampling
//! checkpoints, steps a byte at a time through a 1 KB table (roughly 0.5–1 GB/s); the reader
//! alone steps half a byte at a time through a 64-byte table, which costs a parse about half
//! that speed but keeps 1 KB of incompressible table out of the WebAssembly and
//! microcontroller builds. Both give the same CRC (tested). Chosen over CRC-32 (zlib) for its
//! better error detection on the short bursts typical of storage corruption;
//! hardware-accelerated versions exist everywhere should speed matter.

/// The reflected Castagnoli polynomial.
const POLY: u32 = 0x82F6_3B78;

/// `table::<N>()[i]` is the CRC register after shifting the `log2(N)` bits of `i` through a
/// zero register.
const fn table<const N: usize>() -> [u32; N] {
    let mut table = [0u32; N];
    let mut i = 0;
    while i < N {
        let mut crc = i as u32;
        let mut bit = 1;
        while bit < N {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ POLY
            } else {
                crc >> 1
            };
            bit <<= 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
}

/// The byte-at-a-time table.
#[cfg(any(feature = "bake", test))]
const BYTES: [u32; 256] = table::<256>();

/// The half-byte-at-a-time table.
#[cfg(any(not(feature = "bake"), test))]
const NIBBLES: [u32; 16] = table::<16>();

/// [`crc32c_append`] a byte a step.
#[cfg(any(feature = "bake", test))]
fn by_bytes(crc: u32, data: &[u8]) -> u32 {
    let mut crc = !crc;
    for &byte in data {
        crc = BYTES[((crc ^ byte as u32) & 0xFF) as usize] ^ (crc >> 8);
    }
    !crc
}

/// [`crc32c_append`] half a byte a step.
#[cfg(any(not(feature = "bake"), test))]
fn by_nibbles(crc: u32, data: &[u8]) -> u32 {
    let mut crc = !crc;
    for &byte in data {
        crc ^= byte as u32;
        crc = NIBBLES[(crc & 0xF) as usize] ^ (crc >> 4);
        crc = NIBBLES[(crc & 0xF) as usize] ^ (crc >> 4);
    }
    !crc
}

/// CRC-32C of `data`.
pub fn crc32c(data: &[u8]) -> u32 {
    crc32c_append(0, data)
}

/// CRC-32C of the bytes `crc` was computed over followed by `data`, for checksums of data
/// read piece by piece: `crc32c_append(crc32c(a), b) == crc32c(a ++ b)`.
pub fn crc32c_append(crc: u32, data: &[u8]) -> u32 {
    #[cfg(feature = "bake")]
    return by_bytes(crc, data);
    #[cfg(not(feature = "bake"))]
    return by_nibbles(crc, data);
}

#[cfg(test)]
mod tests {
    use super::crc32c;
    extern crate std;

    #[test]
    fn check_value() {
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
        assert_eq!(crc32c(b""), 0);
        // RFC 3720 (iSCSI) B.4: 32 bytes of zeros.
        assert_eq!(crc32c(&[0u8; 32]), 0x8A91_36AA);
        let piecewise = super::crc32c_append(crc32c(b"1234"), b"56789");
        assert_eq!(piecewise, 0xE306_9283);
    }

    #[test]
    fn both_tables_agree() {
        let data: std::vec::Vec<u8> = (0..4096u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        for n in [0, 1, 7, 100, 4096] {
            assert_eq!(
                super::by_bytes(0, &data[..n]),
                super::by_nibbles(0, &data[..n]),
                "{n} bytes"
            );
        }
    }
}
