//! The vector kernels against their scalar references.

#![allow(clippy::float_cmp)] // exact equality is the property under test

use super::*;
use crate::network::xorshift;

/// The bit of a count that says its position is awake (`network::conv`'s): counts carry it.
const AWAKE: u16 = 1 << 14;

/// `add_rows` (every run length it takes, several rows, strided) equals `add_detect_scalar`
/// row by row.
#[test]
fn add_rows_equals_scalar() {
    let Some(avx2) = Avx2::detect() else {
        return; // add_rows is only called where the CPU has AVX2
    };
    let mut rng = xorshift(11u64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 20) as f32
    };
    let (p_stride, w_stride) = (40, 33);
    for run in 1..=32 {
        for rows in 1..=5 {
            let pot: Vec<f32> = (0..rows * p_stride).map(|_| next() * 2.0).collect();
            let w: Vec<f32> = (0..rows * w_stride).map(|_| next()).collect();
            let thr: Vec<f32> = (0..run).map(|_| next() * 3.0).collect();
            let (p0, w0) = (3, (rows - 1) * w_stride);
            let mut a = pot.clone();
            let mut masks = vec![0u32; rows];
            let any = add_rows(
                avx2, &mut a, p0, p_stride, &w, w0, w_stride, &thr, &mut masks,
            );
            let mut b = pot.clone();
            let mut want = vec![0u32; rows];
            let any_b = add_rows_scalar(&mut b, p0, p_stride, &w, w0, w_stride, &thr, &mut want);
            assert_eq!(masks, want, "run {run}, rows {rows}");
            assert_eq!((a, any), (b, any_b), "run {run}, rows {rows}");
        }
    }
}

/// `add_rows_fixed` equals `add_rows` on its shape, crossings in every lane included.
#[test]
fn add_rows_fixed_equals_add_rows() {
    let Some(avx2) = Avx2::detect() else {
        return; // add_rows_fixed is only called where the CPU has AVX2
    };
    let mut rng = xorshift(13u64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 20) as f32
    };
    let p_stride = 47;
    for round in 0..50 {
        let pot: Vec<f32> = (0..FIXED_ROWS * p_stride).map(|_| next() * 2.0).collect();
        let kernel: [f32; FIXED_KERNEL] = std::array::from_fn(|_| next());
        let thr: [f32; FIXED_RUN] = std::array::from_fn(|_| next() * 3.0);
        let p0 = round % 7;
        // `fresh` only where its promise holds: every lane below its threshold or `−∞`.
        let mut below = pot.clone();
        for r in 0..FIXED_ROWS {
            for (l, &t) in thr.iter().enumerate() {
                let v = &mut below[p0 + r * p_stride + l];
                *v = if (r * FIXED_RUN + l + round) % 7 == 3 {
                    f32::NEG_INFINITY
                } else {
                    let v = t * (next() / 16.0);
                    if v < t {
                        v
                    } else {
                        0.0
                    }
                };
            }
        }
        for (pot, fresh) in [(pot, false), (below.clone(), false), (below, true)] {
            let (mut a, mut b) = (pot.clone(), pot.clone());
            let words = add_rows_fixed::<false>(avx2, &mut a[p0..], p_stride, &kernel, &thr, fresh);
            // Inlined (here into code not compiled for AVX2, where its intrinsics are
            // called): the same.
            let mut c = pot.clone();
            let inlined =
                add_rows_fixed::<true>(avx2, &mut c[p0..], p_stride, &kernel, &thr, fresh);
            assert_eq!(
                (&c, inlined),
                (&a, words),
                "inlined, round {round}, {fresh}"
            );
            // Row r reads the kernel's row FIXED_ROWS − 1 − r.
            let w0 = (FIXED_ROWS - 1) * FIXED_RUN;
            let mut masks = [0u32; FIXED_ROWS];
            let any = add_rows(
                avx2, &mut b, p0, p_stride, &kernel, w0, FIXED_RUN, &thr, &mut masks,
            );
            let mut want = [0u64; 2];
            for (r, &mask) in masks.iter().enumerate() {
                want[r / WORD_ROWS] |= u64::from(mask) << (r % WORD_ROWS * FIXED_RUN);
            }
            assert_eq!((&a, words), (&b, want), "round {round}, {fresh}");
            if fresh {
                // The scalar reference compares the old potentials too: the same words where
                // `fresh` holds.
                let mut d = pot.clone();
                let scalar = add_rows_fixed_scalar(&mut d[p0..], p_stride, &kernel, &thr);
                assert_eq!((&d, scalar), (&a, words), "scalar, round {round}");
            }
            assert_eq!(any, want != [0; 2]);
        }
    }
}

/// The vector kernels add and detect exactly like the scalar loop, at every length and
/// alignment.
#[test]
fn add_detect_equals_scalar() {
    let mut rng = xorshift(7u64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 20) as f32
    };
    // Long runs, whose first crossing (if any) comes in any step of the vector loops.
    for n in 0..80 {
        for (offset, cut) in (0..3).flat_map(|o| [0, n / 3, n / 2, n - n.min(5)].map(|c| (o, c))) {
            let pot: Vec<f32> = (0..n + offset).map(|_| next() * 2.0).collect();
            let w: Vec<f32> = (0..n + offset).map(|_| next()).collect();
            let mut thr: Vec<f32> = (0..n + offset).map(|_| next() * 3.0).collect();
            if let Some(t) = thr.last_mut() {
                *t = f32::INFINITY;
            }
            // No crossing before lane `cut`.
            thr[offset..offset + cut].fill(f32::INFINITY);
            let (mut a, mut b) = (pot.clone(), pot.clone());
            // Masks hold garbage before (they are meaningful only when some lane crossed).
            let (mut ma, mut mb) = (vec![0xa5u8; 16], vec![0u8; 16]);
            let any_a = add_detect(
                Avx2::detect(),
                &mut a[offset..],
                &w[offset..],
                &thr[offset..],
                &mut ma,
            );
            let any_b =
                add_detect_scalar(&mut b[offset..], &w[offset..], &thr[offset..], &mut mb, 0);
            assert_eq!((a, any_a), (b, any_b));
            if any_b {
                assert_eq!(ma[..n.div_ceil(8)], mb[..n.div_ceil(8)]);
            }
            #[cfg(target_arch = "x86_64")]
            {
                let mut c = pot.clone();
                let mut mc = vec![0u8; 16];
                // SAFETY: lengths as required.
                let any_c = unsafe {
                    x86::add_detect_sse2(&mut c[offset..], &w[offset..], &thr[offset..], &mut mc)
                };
                assert_eq!(any_c, any_b);
                assert_eq!(mc[..n.div_ceil(8)], mb[..n.div_ceil(8)]);
            }
            assert!(any_b == mb.iter().any(|&m| m != 0));
        }
    }
}

/// The vector counters count and report like the scalar loop, at every length, and leave
/// the lanes past the run alone.
#[test]
fn count_run_equals_scalar() {
    for len in 0..=LANES {
        for wake_at in [1u16, 2, 3, 7, AWAKE - 1] {
            let start: Vec<u16> = (0..LANES as u16)
                .map(|i| if i % 5 == 4 { AWAKE | i } else { i % 4 })
                .collect();
            let mut want = start.clone();
            let hits = count_run_scalar(&mut want, len, wake_at);
            assert_eq!(want[len..], start[len..]);
            let mut got = start.clone();
            assert_eq!(count_run(Avx2::detect(), &mut got, len, wake_at), hits);
            assert_eq!(got, want);
            #[cfg(target_arch = "x86_64")]
            {
                let mut got = start.clone();
                // SAFETY: LANES counts, len ≤ LANES.
                let sse = unsafe { x86::count_run_sse2(&mut got, len, wake_at) };
                assert_eq!((sse, got), (hits, want));
            }
        }
    }
}

/// The vector stamp test equals the scalar one at every length up to 64.
#[test]
fn fired_mask_equals_scalar() {
    let stamps: Vec<u32> = (0..64u32).map(|i| (i * 7 + i / 5) % 3).collect();
    for n in 0..=64 {
        for generation in 0..3 {
            let want = fired_mask_scalar(&stamps[..n], generation);
            assert_eq!(fired_mask(Avx2::detect(), &stamps[..n], generation), want);
            assert_eq!(
                want.count_ones() as usize,
                stamps[..n].iter().filter(|&&s| s == generation).count()
            );
        }
    }
}

/// The lane-wise minimum equals the scalar one, lanes at their extremes included.
#[test]
fn min_u16x4_equals_scalar() {
    let mut rng = xorshift(5u64);
    let lanes = [0u64, 1, 0x7fff, 0x8000, 0xfffe, 0xffff];
    for _ in 0..2000 {
        let mut pick = || {
            (0..4).fold(0u64, |v, k| {
                let r = rng();
                let lane = if r.is_multiple_of(3) {
                    lanes[(r >> 8) as usize % lanes.len()]
                } else {
                    r >> 48
                };
                v | lane << (16 * k)
            })
        };
        let (a, b) = (pick(), pick());
        assert_eq!(min_u16x4(a, b), min_u16x4_scalar(a, b), "{a:#x} {b:#x}");
    }
}
