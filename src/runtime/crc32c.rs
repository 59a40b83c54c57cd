//! CRC-32C (Castagnoli), the checksum in the `.pvis` trailer (spec § Trailer).
//!
//! Reflected polynomial 0x82F63B78, initial value and final xor 0xFFFFFFFF; the check value of
//! `"123456789"` is 0xE3069283. Table-driven, one byte per step (Sarwate 1988), the table built
//! at compile time. Cost: one table lookup per byte (roughly 0.5–1 GB/s), no allocation.
//! Chosen over CRC-32 (zlib) for its better error detection on the short bursts typical of
//! storage corruption; hardware-accelerated versions exist everywhere should speed matter.

/// The reflected Castagnoli polynomial.
const POLY: u32 = 0x82F6_3B78;

/// `TABLE[b]` is the CRC register after shifting byte `b` through a zero register.
const TABLE: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = i as u32;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ POLY
            } else {
                crc >> 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
};

/// CRC-32C of `data`.
pub fn crc32c(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &byte in data {
        crc = TABLE[((crc ^ byte as u32) & 0xFF) as usize] ^ (crc >> 8);
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::crc32c;

    #[test]
    fn check_value() {
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
        assert_eq!(crc32c(b""), 0);
        // RFC 3720 (iSCSI) B.4: 32 bytes of zeros.
        assert_eq!(crc32c(&[0u8; 32]), 0x8A91_36AA);
    }
}
