//! The AVX2 (and SSE2) kernels of `simd`, with explicit vectors. Only `simd`'s dispatchers call
//! them, each with the proof that the CPU has AVX2 (`Avx2`) where they need it.
//!
//! Each `unsafe` block holds one unsafe operation (a pointer offset, a load, a store, a call)
//! with its own `SAFETY` comment; the ranges a kernel reads and writes are stated once in its
//! `# Safety` section, and each block says which part of them it touches.

use super::{FIXED_KERNEL, FIXED_ROWS, FIXED_RUN, WORD_ROWS};
use std::arch::x86_64::{
    __m256, __m256i, _mm256_add_ps, _mm256_and_ps, _mm256_and_si256, _mm256_castps_si256,
    _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_cmpeq_epi32, _mm256_cmpgt_epi16, _mm256_loadu_ps,
    _mm256_loadu_si256, _mm256_maskload_epi32, _mm256_maskload_ps, _mm256_maskstore_ps,
    _mm256_movemask_epi8, _mm256_movemask_ps, _mm256_or_si256, _mm256_packs_epi16,
    _mm256_packs_epi32, _mm256_permutevar8x32_epi32, _mm256_set1_epi16, _mm256_set1_epi32,
    _mm256_setr_epi32, _mm256_setzero_si256, _mm256_storeu_ps, _mm256_storeu_si256,
    _mm256_sub_epi16, _mm256_testz_si256, _mm256_zextsi128_si256, _mm_add_ps, _mm_and_ps,
    _mm_and_si128, _mm_castps_si128, _mm_cmpge_ps, _mm_cmpgt_epi16, _mm_cmplt_ps, _mm_loadu_ps,
    _mm_loadu_si128, _mm_movemask_epi8, _mm_movemask_ps, _mm_packs_epi32, _mm_set1_epi16,
    _mm_setzero_si128, _mm_storeu_ps, _mm_storeu_si128, _mm_sub_epi16, _CMP_GE_OQ, _CMP_LT_OQ,
};
use std::arch::x86_64::{_mm_cvtsi128_si64, _mm_cvtsi64_si128, _mm_subs_epu16};

/// Eight "on" lanes then eight "off": the window at `8 − r` enables the first `r` lanes.
static TAIL: [i32; 16] = [-1, -1, -1, -1, -1, -1, -1, -1, 0, 0, 0, 0, 0, 0, 0, 0];

/// Sixteen −1 then sixteen 0: the window at `16 − len` is −1 in the first `len` lanes
/// (subtracting it counts one more there).
static ONES: [i16; 32] = {
    let mut a = [0i16; 32];
    let mut i = 0;
    while i < 16 {
        a[i] = -1;
        i += 1;
    }
    a
};

/// # Safety
/// The CPU must support AVX2; `stamps` holds at most 64 values.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn fired_mask_avx2(stamps: &[u32], generation: u32) -> u64 {
    let n = stamps.len();
    let g = _mm256_set1_epi32(generation as i32);
    let mut mask = 0u64;
    let mut i = 0;
    while i + 8 <= n {
        // SAFETY: i + 8 <= n values: the 8 from i are inside `stamps`.
        let at = unsafe { stamps.as_ptr().add(i) };
        // SAFETY: as above (an unaligned load).
        let v = unsafe { _mm256_loadu_si256(at.cast()) };
        let eq = _mm256_castsi256_ps(_mm256_cmpeq_epi32(v, g));
        mask |= u64::from(_mm256_movemask_ps(eq) as u8) << i;
        i += 8;
    }
    if i < n {
        // The last 1-7 stamps in one masked vector (conv1's rows of 5 are nothing else);
        // masked-off lanes read as 0 and are cleared from the mask whatever the generation.
        let rem = n - i;
        // SAFETY: TAIL has 16 values and 8 − rem is in 1..=7: the 8 from it are inside TAIL.
        let window = unsafe { TAIL.as_ptr().add(8 - rem) };
        // SAFETY: as above.
        let lanes = unsafe { _mm256_loadu_si256(window.cast()) };
        // SAFETY: i < n: the first stamp read is inside `stamps`.
        let at = unsafe { stamps.as_ptr().add(i) };
        // SAFETY: the enabled lanes (the first rem) are below n; the others are not read.
        let v = unsafe { _mm256_maskload_epi32(at.cast(), lanes) };
        let eq = _mm256_castsi256_ps(_mm256_cmpeq_epi32(v, g));
        let bits = (_mm256_movemask_ps(eq) as u32) & ((1 << rem) - 1);
        mask |= u64::from(bits) << i;
    }
    mask
}

/// The 2-bits-per-lane byte mask of 16-bit lanes, as 1 bit per lane.
#[inline]
fn lane_bits(mask: u32) -> u32 {
    let mut m = mask & 0x5555_5555;
    m = (m | (m >> 1)) & 0x3333_3333;
    m = (m | (m >> 2)) & 0x0F0F_0F0F;
    m = (m | (m >> 4)) & 0x00FF_00FF;
    (m | (m >> 8)) & 0xFFFF
}

/// # Safety
/// The CPU must support AVX2; `counts` holds `LANES` (16) values and `len <= 16`.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn count_run_avx2(counts: &mut [u16], len: usize, wake_at: u16) -> u32 {
    // Unaligned loads and stores: the casts need no alignment.
    let p = counts.as_mut_ptr();
    // SAFETY: ONES has 32 values with 16 − len in 0..=16: the 16 from it are inside ONES.
    let window = unsafe { ONES.as_ptr().add(16 - len) };
    // SAFETY: as above.
    let inc = unsafe { _mm256_loadu_si256(window.cast()) };
    // SAFETY: `counts` holds 16 values.
    let old = unsafe { _mm256_loadu_si256(p.cast()) };
    let n = _mm256_sub_epi16(old, inc);
    // SAFETY: as above.
    unsafe { _mm256_storeu_si256(p.cast(), n) };
    let at = _mm256_set1_epi16(wake_at as i16 - 1);
    let hit = _mm256_and_si256(_mm256_cmpgt_epi16(n, at), inc);
    lane_bits(_mm256_movemask_epi8(hit) as u32)
}

/// Counts the rows first, keeping only the union of their lanes at or above `wake_at`:
/// nearly always none of the counted lanes is (every position short of waking), and the
/// rows' bit masks are then never built. Otherwise a second pass builds them from the
/// counts just stored.
///
/// # Safety
/// The CPU must support AVX2; for every `r < hits.len()`, `counts + r · stride` holds
/// `LANES` (16) values; `len <= 16`.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn count_rows_avx2(
    counts: *mut u16,
    stride: usize,
    len: usize,
    wake_at: u16,
    hits: &mut [u32],
) -> bool {
    // SAFETY: ONES has 32 values and 16 − len is in 0..=16: the 16 from it are inside ONES.
    let window = unsafe { ONES.as_ptr().add(16 - len) };
    // SAFETY: as above.
    let inc = unsafe { _mm256_loadu_si256(window.cast()) };
    let at = _mm256_set1_epi16(wake_at as i16 - 1);
    let mut reached = _mm256_setzero_si256();
    for r in 0..hits.len() {
        // SAFETY: r < hits.len(): row r holds 16 counts (the caller's contract).
        let p = unsafe { counts.add(r * stride) };
        // SAFETY: as above.
        let old = unsafe { _mm256_loadu_si256(p.cast()) };
        let n = _mm256_sub_epi16(old, inc);
        // SAFETY: as above.
        unsafe { _mm256_storeu_si256(p.cast(), n) };
        reached = _mm256_or_si256(reached, _mm256_cmpgt_epi16(n, at));
    }
    // Lanes past `len` belong to other positions, which this input did not count.
    if _mm256_testz_si256(reached, inc) != 0 {
        return false;
    }
    for (r, h) in hits.iter_mut().enumerate() {
        // SAFETY: r < hits.len(): row r holds 16 counts (the caller's contract).
        let p = unsafe { counts.add(r * stride) };
        // SAFETY: as above.
        let n = unsafe { _mm256_loadu_si256(p.cast()) };
        let hit = _mm256_and_si256(_mm256_cmpgt_epi16(n, at), inc);
        *h = lane_bits(_mm256_movemask_epi8(hit) as u32);
    }
    true
}

/// # Safety
/// `counts` holds `LANES` (16) values and `len <= 16`. (SSE2 is part of x86-64: the
/// `target_feature` only lets the arithmetic intrinsics be called without `unsafe`.)
#[target_feature(enable = "sse2")]
pub(super) unsafe fn count_run_sse2(counts: &mut [u16], len: usize, wake_at: u16) -> u32 {
    let mut mask = 0;
    let at = _mm_set1_epi16(wake_at as i16 - 1);
    for half in 0..2 {
        // SAFETY: 16 counts in two halves of 8: the 8 from 8 · half are inside `counts`.
        let p = unsafe { counts.as_mut_ptr().add(8 * half) };
        // SAFETY: ONES has 32 values with 16 − len in 0..=16: the 8 from this one are inside.
        let window = unsafe { ONES.as_ptr().add(16 - len + 8 * half) };
        // SAFETY: as above.
        let inc = unsafe { _mm_loadu_si128(window.cast()) };
        // SAFETY: the 8 counts from p (above).
        let old = unsafe { _mm_loadu_si128(p.cast()) };
        let n = _mm_sub_epi16(old, inc);
        // SAFETY: as above.
        unsafe { _mm_storeu_si128(p.cast(), n) };
        let hit = _mm_and_si128(_mm_cmpgt_epi16(n, at), inc);
        mask |= (_mm_movemask_epi8(hit) as u32) << (16 * half);
    }
    lane_bits(mask)
}

/// The crossing mask of one vector of lanes.
#[inline]
#[target_feature(enable = "avx2")]
fn crossed(old: __m256, new: __m256, t: __m256) -> i32 {
    _mm256_movemask_ps(_mm256_and_ps(
        _mm256_cmp_ps::<_CMP_LT_OQ>(old, t),
        _mm256_cmp_ps::<_CMP_GE_OQ>(new, t),
    ))
}

/// # Safety
/// The CPU must support AVX2; `w`, `thr` as long as `pot`, `masks` `ceil(len / 8)` bytes.
///
/// Four vectors per step that record no masks while none of their lanes crossed (most runs
/// of conv2 and conv3 have none): at the first step that has some, the masks before it are
/// zero and `add_detect_rest_avx2` records the rest.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn add_detect_avx2(
    pot: &mut [f32],
    w: &[f32],
    thr: &[f32],
    masks: &mut [u8],
) -> bool {
    let n = pot.len();
    let (p, wp, tp, mp) = (
        pot.as_mut_ptr(),
        w.as_ptr(),
        thr.as_ptr(),
        masks.as_mut_ptr(),
    );
    let mut i = 0;
    while i + 32 <= n {
        // SAFETY: i + 32 <= n and the slices hold n values: lanes i..i + 8 are inside.
        let c0 = unsafe { add_vector(p, wp, tp, i) };
        // SAFETY: as above, lanes i + 8..i + 16.
        let c1 = unsafe { add_vector(p, wp, tp, i + 8) };
        // SAFETY: as above, lanes i + 16..i + 24.
        let c2 = unsafe { add_vector(p, wp, tp, i + 16) };
        // SAFETY: as above, lanes i + 24..i + 32.
        let c3 = unsafe { add_vector(p, wp, tp, i + 24) };
        let any = _mm256_or_si256(_mm256_or_si256(c0, c1), _mm256_or_si256(c2, c3));
        if _mm256_testz_si256(any, any) == 0 {
            let bits = |c: __m256i| _mm256_movemask_ps(_mm256_castsi256_ps(c)) as u32;
            let step = bits(c0) | bits(c1) << 8 | bits(c2) << 16 | bits(c3) << 24;
            // SAFETY: i + 32 <= n, the slices hold n values and masks ceil(n / 8) bytes.
            unsafe { add_detect_crossed_avx2(p, wp, tp, mp, n, i, step) };
            return true;
        }
        i += 32;
    }
    // SAFETY: as for this function, from lane i (a multiple of 8).
    let any = unsafe { add_detect_rest_avx2(p, wp, tp, mp, n, i) };
    if any {
        // SAFETY: i / 8 <= n / 8 bytes.
        unsafe { std::ptr::write_bytes(mp, 0, i / 8) };
    }
    any
}

/// The rest of `add_detect_avx2` once the step of the 32 lanes from `i` had crossings
/// (`step`, their masks' 4 bytes): the masks before it are zero, its own are `step`, and
/// the lanes after it are added and recorded. Out of line, so that the loop of
/// `add_detect_avx2` saves no registers for it.
///
/// # Safety
/// As for `add_detect_rest_avx2`, with `i + 32 <= n`.
#[cold]
#[inline(never)]
#[target_feature(enable = "avx2")]
unsafe fn add_detect_crossed_avx2(
    p: *mut f32,
    wp: *const f32,
    tp: *const f32,
    mp: *mut u8,
    n: usize,
    i: usize,
    step: u32,
) {
    // SAFETY: masks hold ceil(n / 8) >= i / 8 + 4 bytes.
    unsafe { std::ptr::write_bytes(mp, 0, i / 8) };
    // SAFETY: as above: byte i / 8 is inside the masks.
    let step_at = unsafe { mp.add(i / 8) }.cast::<[u8; 4]>();
    // SAFETY: as above: the 4 bytes from i / 8 are inside the masks.
    unsafe { step_at.write_unaligned(step.to_le_bytes()) };
    // SAFETY: i + 32 <= n; the slices and masks as the caller guarantees.
    unsafe { add_detect_rest_avx2(p, wp, tp, mp, n, i + 32) };
}

/// `pot += w` for the 8 lanes from `i`: which crossed `thr` (as `crossed_lanes`).
///
/// # Safety
/// The CPU must support AVX2; `p`, `wp` and `tp` hold `i + 8` values.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn add_vector(p: *mut f32, wp: *const f32, tp: *const f32, i: usize) -> __m256i {
    // SAFETY: the caller guarantees the 8 lanes from i of `p`.
    let p = unsafe { p.add(i) };
    // SAFETY: as above, of `wp`.
    let wp = unsafe { wp.add(i) };
    // SAFETY: as above, of `tp`.
    let tp = unsafe { tp.add(i) };
    // SAFETY: the 8 lanes from p (above).
    let old = unsafe { _mm256_loadu_ps(p) };
    // SAFETY: the 8 lanes from wp (above).
    let new = _mm256_add_ps(old, unsafe { _mm256_loadu_ps(wp) });
    // SAFETY: the 8 lanes from p (above).
    unsafe { _mm256_storeu_ps(p, new) };
    // SAFETY: the 8 lanes from tp (above).
    crossed_lanes(old, new, unsafe { _mm256_loadu_ps(tp) })
}

/// `add_detect_avx2` from lane `i` (a multiple of 8) on, recording every mask from byte
/// `i / 8`; returns whether any of these lanes crossed.
///
/// # Safety
/// The CPU must support AVX2; `w`, `thr` and `pot` hold `n` values and `masks`
/// `ceil(n / 8)` bytes; `i <= n`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn add_detect_rest_avx2(
    p: *mut f32,
    wp: *const f32,
    tp: *const f32,
    mp: *mut u8,
    n: usize,
    mut i: usize,
) -> bool {
    let mut any = 0;
    // Two vectors per step: fewer instructions on the loop.
    while i + 16 <= n {
        // i + 16 <= n, the slices hold n values and masks n / 8 bytes: each block below
        // touches lanes i..i + 16 of a slice or bytes i / 8..i / 8 + 2 of the masks.
        // SAFETY: as above.
        let (p0, p1) = (unsafe { p.add(i) }, unsafe { p.add(i + 8) });
        // SAFETY: as above.
        let (w0, w1) = (unsafe { wp.add(i) }, unsafe { wp.add(i + 8) });
        // SAFETY: as above.
        let (t0, t1) = (unsafe { tp.add(i) }, unsafe { tp.add(i + 8) });
        // SAFETY: as above.
        let old0 = unsafe { _mm256_loadu_ps(p0) };
        // SAFETY: as above.
        let new0 = _mm256_add_ps(old0, unsafe { _mm256_loadu_ps(w0) });
        // SAFETY: as above.
        unsafe { _mm256_storeu_ps(p0, new0) };
        // SAFETY: as above.
        let old1 = unsafe { _mm256_loadu_ps(p1) };
        // SAFETY: as above.
        let new1 = _mm256_add_ps(old1, unsafe { _mm256_loadu_ps(w1) });
        // SAFETY: as above.
        unsafe { _mm256_storeu_ps(p1, new1) };
        // SAFETY: as above.
        let mask0 = crossed(old0, new0, unsafe { _mm256_loadu_ps(t0) });
        // SAFETY: as above.
        let mask1 = crossed(old1, new1, unsafe { _mm256_loadu_ps(t1) });
        // SAFETY: as above.
        let m0 = unsafe { mp.add(i / 8) };
        // SAFETY: as above.
        unsafe { *m0 = mask0 as u8 };
        // SAFETY: as above.
        let m1 = unsafe { mp.add(i / 8 + 1) };
        // SAFETY: as above.
        unsafe { *m1 = mask1 as u8 };
        any |= mask0 | mask1;
        i += 16;
    }
    if i + 8 <= n {
        // i + 8 <= n, the slices hold n values and masks n / 8 bytes: each block below
        // touches lanes i..i + 8 of a slice or byte i / 8 of the masks.
        // SAFETY: as above.
        let (p0, w0, t0) = (unsafe { p.add(i) }, unsafe { wp.add(i) }, unsafe {
            tp.add(i)
        });
        // SAFETY: as above.
        let old = unsafe { _mm256_loadu_ps(p0) };
        // SAFETY: as above.
        let new = _mm256_add_ps(old, unsafe { _mm256_loadu_ps(w0) });
        // SAFETY: as above.
        unsafe { _mm256_storeu_ps(p0, new) };
        // SAFETY: as above.
        let mask = crossed(old, new, unsafe { _mm256_loadu_ps(t0) });
        // SAFETY: as above.
        let m0 = unsafe { mp.add(i / 8) };
        // SAFETY: as above.
        unsafe { *m0 = mask as u8 };
        any |= mask;
        i += 8;
    }
    if i < n {
        // The last 1-7 lanes in one masked vector (masked-off lanes are neither read nor
        // written, and compare as 0 < 0: not crossed).
        // TAIL has 16 values and 8 − (n − i) is in 1..=7; lane i is inside each slice and
        // byte i / 8 inside the masks; the enabled lanes are below n.
        // SAFETY: as above.
        let window = unsafe { TAIL.as_ptr().add(8 - (n - i)) };
        // SAFETY: as above.
        let lanes = unsafe { _mm256_loadu_si256(window.cast()) };
        // SAFETY: as above.
        let (p0, w0, t0) = (unsafe { p.add(i) }, unsafe { wp.add(i) }, unsafe {
            tp.add(i)
        });
        // SAFETY: as above.
        let old = unsafe { _mm256_maskload_ps(p0, lanes) };
        // SAFETY: as above.
        let new = _mm256_add_ps(old, unsafe { _mm256_maskload_ps(w0, lanes) });
        // SAFETY: as above.
        unsafe { _mm256_maskstore_ps(p0, lanes, new) };
        // SAFETY: as above.
        let mask = crossed(old, new, unsafe { _mm256_maskload_ps(t0, lanes) });
        // SAFETY: as above.
        let m0 = unsafe { mp.add(i / 8) };
        // SAFETY: as above.
        unsafe { *m0 = mask as u8 };
        any |= mask;
    }
    any != 0
}

/// # Safety
/// The CPU must support AVX2; for every `r < masks.len()`, `pot + r · p_stride` and
/// `w − r · w_stride` hold `thr.len() ≤ 32` values.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn add_rows_avx2(
    pot: *mut f32,
    p_stride: usize,
    w: *const f32,
    w_stride: usize,
    thr: &[f32],
    masks: &mut [u32],
) -> bool {
    let n = thr.len();
    let (full, rem) = (n / 8, n % 8);
    let tp = thr.as_ptr();
    // SAFETY: TAIL has 16 values and 8 − rem is in 1..=8: the 8 from it are inside TAIL.
    let window = unsafe { TAIL.as_ptr().add(8 - rem) };
    // SAFETY: as above.
    let lanes = unsafe { _mm256_loadu_si256(window.cast()) };
    let mut any = 0u32;
    for (r, slot) in masks.iter_mut().enumerate() {
        // SAFETY: the caller guarantees that row r of the potentials holds n values.
        let p = unsafe { pot.add(r * p_stride) };
        // SAFETY: as above, of the weights.
        let wp = unsafe { w.sub(r * w_stride) };
        let mut mask = 0u32;
        for v in 0..full {
            let i = 8 * v;
            // i + 8 <= n values in each row and in thr: each block below touches lanes
            // i..i + 8 of one of them.
            // SAFETY: as above.
            let (p0, w0, t0) = (unsafe { p.add(i) }, unsafe { wp.add(i) }, unsafe {
                tp.add(i)
            });
            // SAFETY: as above.
            let old = unsafe { _mm256_loadu_ps(p0) };
            // SAFETY: as above.
            let new = _mm256_add_ps(old, unsafe { _mm256_loadu_ps(w0) });
            // SAFETY: as above.
            unsafe { _mm256_storeu_ps(p0, new) };
            // SAFETY: as above.
            mask |= (crossed(old, new, unsafe { _mm256_loadu_ps(t0) }) as u32) << i;
        }
        if rem > 0 {
            let i = 8 * full;
            // Lane i is inside each row and thr, and the enabled lanes are below n
            // (masked-off lanes are neither read nor written, and compare as 0 < 0: not
            // crossed).
            // SAFETY: as above.
            let (p0, w0, t0) = (unsafe { p.add(i) }, unsafe { wp.add(i) }, unsafe {
                tp.add(i)
            });
            // SAFETY: as above.
            let old = unsafe { _mm256_maskload_ps(p0, lanes) };
            // SAFETY: as above.
            let new = _mm256_add_ps(old, unsafe { _mm256_maskload_ps(w0, lanes) });
            // SAFETY: as above.
            unsafe { _mm256_maskstore_ps(p0, lanes, new) };
            // SAFETY: as above.
            mask |= (crossed(old, new, unsafe { _mm256_maskload_ps(t0, lanes) }) as u32) << i;
        }
        *slot = mask;
        any |= mask;
    }
    any != 0
}

/// Which lanes crossed (all ones) and which did not (zero), of one vector.
#[inline]
#[target_feature(enable = "avx2")]
fn crossed_lanes(old: __m256, new: __m256, t: __m256) -> __m256i {
    _mm256_castps_si256(_mm256_and_ps(
        _mm256_cmp_ps::<_CMP_LT_OQ>(old, t),
        _mm256_cmp_ps::<_CMP_GE_OQ>(new, t),
    ))
}

/// `super::add_rows_fixed`: two full vectors and one half vector per row, whose crossing
/// lanes are packed to bytes (in lane order, by one permutation) for a single movemask per
/// row. With `fresh`, a lane crossed where its new potential is at or above its threshold.
/// Returns the two words of crossing lanes.
///
/// # Safety
/// The CPU must support AVX2; for every `r < FIXED_ROWS`, `pot + r · p_stride` holds
/// `FIXED_RUN` values.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn add_rows_fixed_avx2(
    pot: *mut f32,
    p_stride: usize,
    kernel: &[f32; FIXED_KERNEL],
    thr: &[f32; FIXED_RUN],
    fresh: bool,
) -> (u64, u64) {
    // SAFETY: as for this function.
    unsafe { add_rows_fixed_body(pot, p_stride, kernel, thr, fresh) }
}

/// The body of `add_rows_fixed_avx2`, inlined into each caller: compiled for AVX2 only
/// where the caller is (`add_rows_fixed` with `INLINE`), so that it is then inlined whole.
///
/// # Safety
/// As for `add_rows_fixed_avx2`.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(super) unsafe fn add_rows_fixed_body(
    pot: *mut f32,
    p_stride: usize,
    kernel: &[f32; FIXED_KERNEL],
    thr: &[f32; FIXED_RUN],
    fresh: bool,
) -> (u64, u64) {
    const _: () = assert!(FIXED_RUN == 20, "two vectors and a half per row");
    // Every intrinsic below needs the CPU to have AVX2 (the caller's contract); the
    // thresholds' loads read thr's FIXED_RUN values.
    // SAFETY: as above, lanes 0..8.
    let t0 = unsafe { _mm256_loadu_ps(thr.as_ptr()) };
    // SAFETY: as above: lanes 8 and 16 are inside thr.
    let (thr1, thr2) = (unsafe { thr.as_ptr().add(8) }, unsafe {
        thr.as_ptr().add(16)
    });
    // SAFETY: as above, lanes 8..16.
    let t1 = unsafe { _mm256_loadu_ps(thr1) };
    // SAFETY: as above, lanes 16..20.
    let t2 = unsafe { _mm_loadu_ps(thr2) };
    // After the packs, the 32-bit groups of bytes hold lanes 0-3, 8-11, 16-19, none, 4-7,
    // 12-15, none, none: this puts them back in order.
    // SAFETY: the CPU has AVX2 (the caller's contract).
    let order = unsafe { _mm256_setr_epi32(0, 4, 1, 5, 2, 3, 6, 7) };
    let mut words = [0u64; 2];
    for r in 0..FIXED_ROWS {
        // The caller guarantees that row r of the potentials holds FIXED_RUN values (lanes
        // 0..8, 8..16 and 16..20 below); the kernel's row `FIXED_ROWS − 1 − r`, of as many,
        // is inside it; the CPU has AVX2.
        // SAFETY: as above.
        let p = unsafe { pot.add(r * p_stride) };
        // SAFETY: as above.
        let wp = unsafe { kernel.as_ptr().add((FIXED_ROWS - 1 - r) * FIXED_RUN) };
        // SAFETY: as above.
        let (p1, p2) = (unsafe { p.add(8) }, unsafe { p.add(16) });
        // SAFETY: as above.
        let (wp1, wp2) = (unsafe { wp.add(8) }, unsafe { wp.add(16) });
        // SAFETY: as above.
        let old0 = unsafe { _mm256_loadu_ps(p) };
        // SAFETY: as above.
        let w0 = unsafe { _mm256_loadu_ps(wp) };
        // SAFETY: as above.
        let new0 = unsafe { _mm256_add_ps(old0, w0) };
        // SAFETY: as above.
        unsafe { _mm256_storeu_ps(p, new0) };
        // SAFETY: as above.
        let old1 = unsafe { _mm256_loadu_ps(p1) };
        // SAFETY: as above.
        let w1 = unsafe { _mm256_loadu_ps(wp1) };
        // SAFETY: as above.
        let new1 = unsafe { _mm256_add_ps(old1, w1) };
        // SAFETY: as above.
        unsafe { _mm256_storeu_ps(p1, new1) };
        // SAFETY: as above.
        let old2 = unsafe { _mm_loadu_ps(p2) };
        // SAFETY: as above.
        let w2 = unsafe { _mm_loadu_ps(wp2) };
        // SAFETY: as above.
        let new2 = unsafe { _mm_add_ps(old2, w2) };
        // SAFETY: as above.
        unsafe { _mm_storeu_ps(p2, new2) };
        let (c0, c1, c2) = if fresh {
            // SAFETY: as above.
            let ge0 = unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(new0, t0) };
            // SAFETY: as above.
            let ge1 = unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(new1, t1) };
            // SAFETY: as above.
            let ge2 = unsafe { _mm_cmpge_ps(new2, t2) };
            // SAFETY: as above.
            let c0 = unsafe { _mm256_castps_si256(ge0) };
            // SAFETY: as above.
            let c1 = unsafe { _mm256_castps_si256(ge1) };
            // SAFETY: as above.
            let c2 = unsafe { _mm_castps_si128(ge2) };
            (c0, c1, c2)
        } else {
            // SAFETY: as above.
            let lt2 = unsafe { _mm_cmplt_ps(old2, t2) };
            // SAFETY: as above.
            let ge2 = unsafe { _mm_cmpge_ps(new2, t2) };
            // SAFETY: as above.
            let both2 = unsafe { _mm_and_ps(lt2, ge2) };
            // SAFETY: as above.
            let c0 = unsafe { crossed_lanes(old0, new0, t0) };
            // SAFETY: as above.
            let c1 = unsafe { crossed_lanes(old1, new1, t1) };
            // SAFETY: as above.
            let c2 = unsafe { _mm_castps_si128(both2) };
            (c0, c1, c2)
        };
        // SAFETY: the CPU has AVX2 (the caller's contract).
        let halves = unsafe { _mm256_packs_epi32(c0, c1) };
        // SAFETY: as above.
        let zero = unsafe { _mm_setzero_si128() };
        // SAFETY: as above.
        let tail = unsafe { _mm_packs_epi32(c2, zero) };
        // SAFETY: as above.
        let tail = unsafe { _mm256_zextsi128_si256(tail) };
        // SAFETY: as above.
        let packed = unsafe { _mm256_packs_epi16(halves, tail) };
        // SAFETY: as above.
        let bytes = unsafe { _mm256_permutevar8x32_epi32(packed, order) };
        // SAFETY: as above.
        let mask = u64::from(unsafe { _mm256_movemask_epi8(bytes) } as u32);
        words[r / WORD_ROWS] |= mask << (r % WORD_ROWS * FIXED_RUN);
    }
    (words[0], words[1])
}

/// # Safety
/// `w`, `thr` as long as `pot`, `masks` `ceil(len / 8)` bytes. (SSE2 is part of x86-64: the
/// `target_feature` only lets the arithmetic intrinsics be called without `unsafe`.)
#[target_feature(enable = "sse2")]
pub(super) unsafe fn add_detect_sse2(
    pot: &mut [f32],
    w: &[f32],
    thr: &[f32],
    masks: &mut [u8],
) -> bool {
    let n = pot.len();
    let (p, wp, tp, mp) = (
        pot.as_mut_ptr(),
        w.as_ptr(),
        thr.as_ptr(),
        masks.as_mut_ptr(),
    );
    let mut any = 0;
    let mut i = 0;
    while i + 8 <= n {
        let mut mask = 0;
        for half in 0..2 {
            let j = i + 4 * half;
            // j + 4 <= n and the slices hold n values: each block below touches lanes
            // j..j + 4 of one of them.
            // SAFETY: as above.
            let (p0, w0, t0) = (unsafe { p.add(j) }, unsafe { wp.add(j) }, unsafe {
                tp.add(j)
            });
            // SAFETY: as above.
            let old = unsafe { _mm_loadu_ps(p0) };
            // SAFETY: as above.
            let new = _mm_add_ps(old, unsafe { _mm_loadu_ps(w0) });
            // SAFETY: as above.
            unsafe { _mm_storeu_ps(p0, new) };
            // SAFETY: as above.
            let t = unsafe { _mm_loadu_ps(t0) };
            mask |= _mm_movemask_ps(_mm_and_ps(_mm_cmplt_ps(old, t), _mm_cmpge_ps(new, t)))
                << (4 * half);
        }
        // SAFETY: i / 8 < n / 8 bytes: byte i / 8 is inside the masks.
        let m0 = unsafe { mp.add(i / 8) };
        // SAFETY: as above.
        unsafe { *m0 = mask as u8 };
        any |= mask;
        i += 8;
    }
    let tail = i < n && super::add_detect_scalar(pot, w, thr, masks, i);
    any != 0 || tail
}

/// `super::min_u16x4`: the unsigned minimum is a − (a −sat b).
#[inline]
pub(super) fn min_u16x4(a: u64, b: u64) -> u64 {
    // SAFETY: SSE2 is part of x86-64.
    let va = unsafe { _mm_cvtsi64_si128(a as i64) };
    // SAFETY: as above.
    let vb = unsafe { _mm_cvtsi64_si128(b as i64) };
    // SAFETY: as above.
    let diff = unsafe { _mm_subs_epu16(va, vb) };
    // SAFETY: as above.
    let min = unsafe { _mm_sub_epi16(va, diff) };
    // SAFETY: as above.
    unsafe { _mm_cvtsi128_si64(min) as u64 }
}
