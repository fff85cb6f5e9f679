//! The recorded sequence, cut from a recording at build time by `build.rs`.
include!(concat!(env!("OUT_DIR"), "/sequence_meta.rs"));

/// 6 bytes per sample: gyro x, y, z counts and the thruster word, 12 bits each, little endian.
static BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/sequence.bin"));

/// The samples in order: (gyro counts, thruster word).
pub fn samples() -> impl Iterator<Item = ([u16; 3], u16)> {
    BLOB.chunks_exact(6).map(|c| {
        let mut bytes = [0u8; 8];
        for (d, s) in bytes.iter_mut().zip(c.iter()) {
            *d = *s;
        }
        let packed = u64::from_le_bytes(bytes);
        let field = |k: u32| ((packed >> (12 * k)) & 0xfff) as u16;
        ([field(0), field(1), field(2)], field(3))
    })
}
