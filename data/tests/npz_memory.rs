//! Peak memory of writing and reading an `.npz` archive, measured with a counting allocator:
//! both stream, so the peak above what the caller holds is about the array itself (reading) or
//! the compressor's buffers (writing), not the 2× of a copy of the whole archive in memory.

#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use fieldprobe_data::dataset::npy::{NpyArray, read_npz_key, write_npz};

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards every call to the system allocator unchanged; it only counts bytes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Bytes allocated at the peak of `f` above what was live before it.
fn peak_of<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let before = LIVE.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    let out = f();
    (out, PEAK.load(Ordering::Relaxed) - before)
}

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
