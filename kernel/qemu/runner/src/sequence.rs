//! The recorded sequence, cut from a recording at build time by `build.rs`.
include!(concat!(env!("OUT_DIR"), "/sequence_meta.rs"));

/// 8 bytes per sample: gyro x, y, z counts and the thruster word, u16 little endian.
static BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/sequence.bin"));

/// The samples in order: (gyro counts, thruster word).
pub fn samples() -> impl Iterator<Item = ([u16; 3], u16)> {
    BLOB.chunks_exact(8).map(|c| {
        let mut w = [0u16; 4];
        for (v, b) in w.iter_mut().zip(c.chunks_exact(2)) {
            let mut pair = [0u8; 2];
            pair.copy_from_slice(b);
            *v = u16::from_le_bytes(pair);
        }
        ([w[0], w[1], w[2]], w[3])
    })
}
