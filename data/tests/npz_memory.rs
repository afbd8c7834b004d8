//! Peak memory of writing and reading an `.npz` archive, measured with a counting allocator:
//! both stream, so the peak above what the caller holds is about the array itself (reading) or
//! the compressor's buffers (writing), not the 2× of a copy of the whole archive in memory.

mod common;

use common::peak_of;
use fieldprobe_data::dataset::npy::{NpyArray, read_npz_key, write_npz};

#[test]
fn npz_write_and_read_peak_at_about_the_array() {
    const N: usize = 32 << 20;
    // Pseudo-random bytes, so that deflate cannot shrink the problem away.
    let mut x = 0x9E37_79B9u32;
    let data: Vec<u8> = (0..N)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 24) as u8
        })
        .collect();
    let array = NpyArray::from_u8(vec![N], data);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.npz");
    let ((), write_peak) = peak_of(|| write_npz(&path, &[("arr_0", &array)]).unwrap());
    let (back, read_peak) = peak_of(|| read_npz_key(&path, "arr_0").unwrap());
    assert_eq!(back, array);
    eprintln!(
        "array {} MiB: write peak {:.2} MiB, read peak {:.2} MiB (above what the caller held)",
        N >> 20,
        write_peak as f64 / (1 << 20) as f64,
        read_peak as f64 / (1 << 20) as f64
    );
    assert!(
        write_peak < N / 4,
        "writing copies the archive: {write_peak} bytes"
    );
    assert!(
        read_peak < N + N / 8,
        "reading holds more than the array: {read_peak} bytes"
    );
}
