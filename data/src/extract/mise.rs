//! MISE: sampling the field on the finest grid where it matters (see the module docs of
//! [`super`] for the rules).

use super::ExtractOptions;

const UNKNOWN: u8 = 0;
const QUEUED: u8 = 1;
const KNOWN: u8 = 2;

/// The finest grid's samples (`(n+1)³`, `[x][y][z]`, z fastest), evaluated or filled.
pub(super) struct Samples {
    /// Cells per axis of the finest grid.
    pub n: usize,
    pub values: Vec<f32>,
}

/// Runs MISE. `lo` and `h` place sample `i` of an axis at `lo + i·h`.
pub(super) fn sample(
    field: &mut dyn FnMut(&[f32]) -> Vec<f32>,
    opts: &ExtractOptions,
    lo: f64,
    h: f64,
) -> Samples {
    let levels = opts.refinements;
    let n = opts.resolution << levels;
    let np = n + 1;
    let idx = |i: usize, j: usize, k: usize| (i * np + j) * np + k;
    let mut values = vec![f32::NAN; np * np * np];
    let mut state = vec![UNKNOWN; np * np * np];
    let t = opts.level();

    let mut evaluate = |queue: &[usize], values: &mut [f32], state: &mut [u8]| {
        let mut coords = Vec::with_capacity(queue.len().min(opts.batch_size) * 3);
        for chunk in queue.chunks(opts.batch_size) {
            coords.clear();
            for &p in chunk {
                let (i, j, k) = (p / (np * np), (p / np) % np, p % np);
                for g in [i, j, k] {
                    coords.push((lo + g as f64 * h) as f32);
                }
            }
            let out = field(&coords);
            assert_eq!(
                out.len(),
                chunk.len(),
                "extract_mesh: the field returned {} values for {} points",
                out.len(),
                chunk.len()
            );
            for (&p, v) in chunk.iter().zip(out) {
                values[p] = v;
                state[p] = KNOWN;
            }
        }
    };

    // Level 0: the whole coarse grid.
    let s0 = 1usize << levels;
    let r = opts.resolution;
    let mut queue = Vec::with_capacity((r + 1).pow(3));
    for i in 0..=r {
        for j in 0..=r {
            for k in 0..=r {
                queue.push(idx(i * s0, j * s0, k * s0));
            }
        }
    }
    evaluate(&queue, &mut values, &mut state);

    for level in 0..levels {
        // Level-`level` cells have `cells` per axis and span `s` finest cells.
        let s = 1usize << (levels - level);
        let cells = r << level;
        let half = s / 2;

        // Active cells: their eight corner values straddle t.
        let cidx = |a: usize, b: usize, c: usize| (a * cells + b) * cells + c;
        let mut active = vec![false; cells * cells * cells];
        for a in 0..cells {
            for b in 0..cells {
                for c in 0..cells {
                    let (mut any_in, mut any_out) = (false, false);
                    for corner in 0..8 {
                        let v = values[idx(
                            (a + (corner & 1)) * s,
                            (b + ((corner >> 1) & 1)) * s,
                            (c + ((corner >> 2) & 1)) * s,
                        )];
                        if v >= t {
                            any_in = true;
                        } else {
                            any_out = true;
                        }
                    }
                    active[cidx(a, b, c)] = any_in && any_out;
                }
            }
        }
        if opts.refine_neighbours {
            dilate(&mut active, cells);
        }

        // New points: the 3×3×3 finer samples of every active cell not evaluated yet.
        queue.clear();
        for a in 0..cells {
            for b in 0..cells {
                for c in 0..cells {
                    if !active[cidx(a, b, c)] {
                        continue;
                    }
                    for u in 0..3 {
                        for v in 0..3 {
                            for w in 0..3 {
                                let p = idx(a * s + u * half, b * s + v * half, c * s + w * half);
                                if state[p] == UNKNOWN {
                                    state[p] = QUEUED;
                                    queue.push(p);
                                }
                            }
                        }
                    }
                }
            }
        }
        evaluate(&queue, &mut values, &mut state);

        // Fill the rest of level `level + 1` by trilinear interpolation of level `level`.
        let m = cells * 2;
        let parents = |a: usize| {
            if a.is_multiple_of(2) {
                [a / 2 * s, usize::MAX]
            } else {
                [a / 2 * s, (a / 2 + 1) * s]
            }
        };
        for a in 0..=m {
            for b in 0..=m {
                for c in 0..=m {
                    let p = idx(a * half, b * half, c * half);
                    if state[p] == KNOWN {
                        continue;
                    }
                    let (pa, pb, pc) = (parents(a), parents(b), parents(c));
                    let (mut sum, mut count) = (0f64, 0u32);
                    for &x in pa.iter().filter(|&&x| x != usize::MAX) {
                        for &y in pb.iter().filter(|&&y| y != usize::MAX) {
                            for &z in pc.iter().filter(|&&z| z != usize::MAX) {
                                sum += f64::from(values[idx(x, y, z)]);
                                count += 1;
                            }
                        }
                    }
                    values[p] = (sum / f64::from(count)) as f32;
                }
            }
        }
    }

    Samples { n, values }
}

/// Marks the 26 neighbours of every marked cell (a 3×3×3 max filter, one axis at a time).
fn dilate(mask: &mut [bool], cells: usize) {
    let strides = [cells * cells, cells, 1];
    for stride in strides {
        let src = mask.to_vec();
        for (p, m) in mask.iter_mut().enumerate() {
            let coord = (p / stride) % cells;
            *m = src[p] || (coord > 0 && src[p - stride]) || (coord + 1 < cells && src[p + stride]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dilate_marks_the_26_neighbours() {
        let n = 5;
        let mut mask = vec![false; n * n * n];
        mask[(2 * n + 2) * n + 2] = true;
        mask[0] = true;
        dilate(&mut mask, n);
        let count = mask.iter().filter(|&&m| m).count();
        assert_eq!(count, 27 + 8 - 1, "the two blocks share cell (1, 1, 1)");
        assert!(mask[(n + 1) * n + 1] && mask[(3 * n + 3) * n + 3] && !mask[(4 * n + 4) * n + 4]);
    }
}
