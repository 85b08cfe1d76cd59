//! The one module that knows about the CPU: whether it has AVX2 (asked once, as a token), the
//! vector kernels of the engine beside their scalar references, and the dispatchers that pick
//! one of them from the token.
//!
//! **The token.** An [`Avx2`] is made only by [`Avx2::detect`], where the CPU has AVX2; states
//! hold an `Option<Avx2>` (never a `bool`), and every function that runs AVX2 code takes one.
//! So no safe function can be told "the CPU has AVX2" without it being true, and the `unsafe`
//! blocks that enter AVX2 code all rest on one fact: the token exists. Engine code that only
//! needs its own loops compiled for AVX2 (so that the kernels inline into them) passes them to
//! [`Avx2::vectorize`] instead of declaring `#[target_feature]` functions of its own.
//!
//! **Why no crate.** `pulp` and `multiversion` were weighed. `multiversion` clones a function
//! per target and dispatches on each call; the engine's hot loops already choose once per
//! window and hold the choice, and its kernels are explicit intrinsics that a clone would not
//! write for us. `pulp` brings its own vector types (`Simd` trait, `WithSimd`) and the work of
//! rewriting the kernels in them, for the one feature level (AVX2) the engine uses. What both
//! would give — a proof type and "compile this closure for the feature" — is the ~40 lines of
//! `Avx2` below on safe `#[target_feature]` functions (Rust 1.86) whose intrinsics are safe
//! to call (1.87): no dependency, no layer, and `rust-version` says 1.87 (see Cargo.toml).
//!
//! **Who may call what.** Only `simd` names `std::arch` or `#[target_feature]`; the engine
//! (`network::conv`, `network::window`, `network::cause`) calls the dispatchers here, with the
//! token its state holds.

#[cfg(target_arch = "x86_64")]
mod x86;

/// Counter lanes of one vector: one output row's positions of one input (`k ≤ LANES`).
pub(crate) const LANES: usize = 16;

/// The one shape that `add_rows_fixed` takes: conv1's input spike away from the borders adds
/// to `k = 5` output rows of `k × maps = 5 × 4` lanes each.
pub(crate) const FIXED_ROWS: usize = 5;
pub(crate) const FIXED_RUN: usize = 20;
/// The weights of one input channel of such a layer (`k × k × maps`, engine layout).
pub(crate) const FIXED_KERNEL: usize = FIXED_ROWS * FIXED_RUN;
/// Rows of a whole footprint per word of `add_rows_fixed`'s result (3 × 20 lanes ≤ 64).
pub(crate) const WORD_ROWS: usize = 3;
const _: () = assert!(
    WORD_ROWS * FIXED_RUN <= 64 && FIXED_ROWS <= 2 * WORD_ROWS,
    "a whole footprint's lanes in two words"
);

/// What an `Avx2` holds: nothing on x86-64; on other targets a value that cannot exist, so
/// that code taking a token there is known unreachable.
#[cfg(target_arch = "x86_64")]
type Proof = ();
#[cfg(not(target_arch = "x86_64"))]
type Proof = std::convert::Infallible;

/// Proof that the CPU has AVX2: made only by [`Avx2::detect`], so that code holding one may
/// run AVX2 code without asking again.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Avx2(Proof);

impl Avx2 {
    /// The token where the CPU has AVX2. The CPU is asked once per process (the standard
    /// library keeps the answer); states call this at construction and keep the result.
    pub(crate) fn detect() -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx2").then_some(Self(()))
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            None
        }
    }

    /// Run `f` in a function compiled for AVX2, so that what it inlines (pass it an
    /// `#[inline(always)]` closure calling `#[inline(always)]` code) is compiled for AVX2 too,
    /// and the AVX2 kernels that code calls inline into it.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub(crate) fn vectorize<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2")]
            fn run<R>(f: impl FnOnce() -> R) -> R {
                f()
            }
            let Self(()) = self;
            // SAFETY: `self` exists, so the CPU has AVX2 (`detect`).
            unsafe { run(f) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = f;
            match self.0 {}
        }
    }
}

/// Bit `b` set where `stamps[b] == generation`, for up to 64 stamps.
#[inline]
pub(crate) fn fired_mask(avx2: Option<Avx2>, stamps: &[u32], generation: u32) -> u64 {
    assert!(stamps.len() <= 64, "at most 64 stamps");
    #[cfg(target_arch = "x86_64")]
    if avx2.is_some() {
        // SAFETY: the token proves AVX2; the length is asserted above.
        return unsafe { x86::fired_mask_avx2(stamps, generation) };
    }
    let _ = avx2;
    fired_mask_scalar(stamps, generation)
}

/// The scalar version of `fired_mask`.
pub(crate) fn fired_mask_scalar(stamps: &[u32], generation: u32) -> u64 {
    let mut mask = 0;
    for (b, &stamp) in stamps.iter().enumerate() {
        mask |= u64::from(stamp == generation) << b;
    }
    mask
}

/// Count one more fired input at the first `len` positions of `counts` (which holds `LANES`
/// values); returns bit `d` set for each of them whose count is now at least `wake_at`
/// (awake ones included). The other lanes are left as they are.
#[inline]
pub(crate) fn count_run(avx2: Option<Avx2>, counts: &mut [u16], len: usize, wake_at: u16) -> u32 {
    assert!(
        counts.len() == LANES && len <= LANES,
        "one vector of counts"
    );
    #[cfg(target_arch = "x86_64")]
    {
        if avx2.is_some() {
            // SAFETY: the lengths are asserted above; the token proves AVX2.
            unsafe { x86::count_run_avx2(counts, len, wake_at) }
        } else {
            // SAFETY: the lengths are asserted above; SSE2 is part of x86-64.
            unsafe { x86::count_run_sse2(counts, len, wake_at) }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = avx2;
        count_run_scalar(counts, len, wake_at)
    }
}

/// The scalar version of `count_run`.
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
pub(crate) fn count_run_scalar(counts: &mut [u16], len: usize, wake_at: u16) -> u32 {
    let mut hits = 0;
    for (d, n) in counts[..len].iter_mut().enumerate() {
        *n += 1;
        hits |= u32::from(*n >= wake_at) << d;
    }
    hits
}

/// `count_run` for the `hits.len()` output rows of one input at once: row `r` counts at
/// `counts[p0 + r · stride ..][..len]`, `hits[r]` gets its bits. Returns whether any is set.
#[inline]
pub(crate) fn count_rows(
    avx2: Option<Avx2>,
    counts: &mut [u16],
    p0: usize,
    stride: usize,
    len: usize,
    wake_at: u16,
    hits: &mut [u32],
) -> bool {
    let rows = hits.len();
    if rows == 0 {
        return false;
    }
    assert!(
        len <= LANES && p0 + (rows - 1) * stride + LANES <= counts.len(),
        "rows of counts inside the layer"
    );
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = avx2 {
        // SAFETY: the rows are asserted above (each holds LANES counts).
        return unsafe {
            count_rows_unchecked(avx2, &mut counts[p0..], stride, len, wake_at, hits)
        };
    }
    let mut any = 0;
    for (r, h) in hits.iter_mut().enumerate() {
        let p = p0 + r * stride;
        *h = count_run(avx2, &mut counts[p..p + LANES], len, wake_at);
        any |= *h;
    }
    any != 0
}

/// `count_rows` from `counts[0]` without the bounds test, for a caller that checked the rows
/// once: counts the rows first, keeping only the union of their lanes at or above `wake_at`
/// (nearly always none: every position short of waking, and the rows' bit masks are then
/// never built). Inlined, so that a caller compiled for AVX2 (`vectorize`) takes it whole.
///
/// # Safety
/// For every `r < hits.len()`, `counts[r · stride..]` holds `LANES` values; `len ≤ LANES`.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) unsafe fn count_rows_unchecked(
    avx2: Avx2,
    counts: &mut [u16],
    stride: usize,
    len: usize,
    wake_at: u16,
    hits: &mut [u32],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        let _ = avx2;
        // SAFETY: the token proves AVX2; the rows are the caller's contract.
        unsafe { x86::count_rows_avx2(counts.as_mut_ptr(), stride, len, wake_at, hits) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (counts, stride, len, wake_at, hits);
        match avx2.0 {}
    }
}

/// `pot += w`; returns whether any lane `l` went from below its threshold `thr` to at or above
/// it, and if so bit `l % 8` of `masks[l / 8]` tells whether lane `l` did (else `masks` may be
/// left as they were). One pass with explicit AVX2 (picked at run time) or SSE2 vectors;
/// `masks` holds at least `ceil(len / 8)` bytes.
#[inline]
pub(crate) fn add_detect(
    avx2: Option<Avx2>,
    pot: &mut [f32],
    w: &[f32],
    thr: &[f32],
    masks: &mut [u8],
) -> bool {
    let n = pot.len();
    assert!(
        w.len() >= n && thr.len() >= n && masks.len() >= n.div_ceil(8),
        "runs of equal length"
    );
    #[cfg(target_arch = "x86_64")]
    {
        if avx2.is_some() {
            // SAFETY: the lengths are asserted above; the token proves AVX2.
            unsafe { x86::add_detect_avx2(pot, w, thr, masks) }
        } else {
            // SAFETY: the lengths are asserted above; SSE2 is part of x86-64.
            unsafe { x86::add_detect_sse2(pot, w, thr, masks) }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = avx2;
        add_detect_scalar(pot, w, thr, masks, 0)
    }
}

/// The scalar version of `add_detect`, from lane `from` (a multiple of 8) to the end.
#[inline]
pub(crate) fn add_detect_scalar(
    pot: &mut [f32],
    w: &[f32],
    thr: &[f32],
    masks: &mut [u8],
    from: usize,
) -> bool {
    let mut any = 0u8;
    let chunks = from / 8..pot.len().div_ceil(8);
    for (chunk, slot) in chunks.clone().zip(&mut masks[chunks]) {
        let mut mask = 0u8;
        for i in chunk * 8..(chunk * 8 + 8).min(pot.len()) {
            let old = pot[i];
            let new = old + w[i];
            pot[i] = new;
            mask |= u8::from(old < thr[i] && new >= thr[i]) << (i % 8);
        }
        *slot = mask;
        any |= mask;
    }
    any != 0
}

/// Whether `rows ≥ 1` rows of `run` lanes lie inside `pot` and `w`: row `r`'s potentials from
/// `p0 + r · p_stride` and its weights from `w0 − r · w_stride` (what the AVX2 row adders read
/// and write without bounds checks).
#[inline]
fn rows_inside(
    pot: &[f32],
    p0: usize,
    p_stride: usize,
    w: &[f32],
    w0: usize,
    w_stride: usize,
    run: usize,
    rows: usize,
) -> bool {
    p0 + (rows - 1) * p_stride + run <= pot.len()
        && w0 >= (rows - 1) * w_stride
        && w0 + run <= w.len()
}

/// `add_detect` for the `masks.len()` output rows of one input at once (AVX2 only): row `r`
/// adds the run of weights at `w0 − r · w_stride` to the potentials at `p0 + r · p_stride`
/// (runs of `thr.len() ≤ 32` lanes); `masks[r]` gets bit `l` where lane `l` of row `r`
/// crossed. Returns whether any did. One call per input spike and no branch on the data
/// between rows, so that the rows' loads overlap. (`add_rows_scalar` is its reference.)
#[inline]
pub(crate) fn add_rows(
    avx2: Avx2,
    pot: &mut [f32],
    p0: usize,
    p_stride: usize,
    w: &[f32],
    w0: usize,
    w_stride: usize,
    thr: &[f32],
    masks: &mut [u32],
) -> bool {
    let (run, rows) = (thr.len(), masks.len());
    if rows == 0 {
        return false;
    }
    assert!(
        run <= 32 && rows_inside(pot, p0, p_stride, w, w0, w_stride, run, rows),
        "rows inside the layer and the kernel"
    );
    #[cfg(target_arch = "x86_64")]
    {
        let _ = avx2;
        // SAFETY: `p0` is inside `pot` (asserted above).
        let p = unsafe { pot.as_mut_ptr().add(p0) };
        // SAFETY: `w0` is inside `w` (asserted above).
        let q = unsafe { w.as_ptr().add(w0) };
        // SAFETY: the rows are inside `pot` and `w` (asserted above); the token proves AVX2.
        unsafe { x86::add_rows_avx2(p, p_stride, q, w_stride, thr, masks) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (pot, p0, p_stride, w, w0, w_stride);
        match avx2.0 {}
    }
}

/// The scalar version of `add_rows`.
#[cfg(test)]
pub(crate) fn add_rows_scalar(
    pot: &mut [f32],
    p0: usize,
    p_stride: usize,
    w: &[f32],
    w0: usize,
    w_stride: usize,
    thr: &[f32],
    masks: &mut [u32],
) -> bool {
    let run = thr.len();
    let mut any = false;
    let mut bytes = [0u8; 4];
    for (r, mask) in masks.iter_mut().enumerate() {
        let (p, q) = (p0 + r * p_stride, w0 - r * w_stride);
        any |= add_detect_scalar(&mut pot[p..p + run], &w[q..q + run], thr, &mut bytes, 0);
        *mask = u32::from_le_bytes(bytes);
    }
    any
}

/// `add_rows` for `FIXED_ROWS` rows of `FIXED_RUN` lanes (AVX2 only): row `r`'s potentials
/// from `pot[r · p_stride]`, its weights the kernel's row `FIXED_ROWS − 1 − r` (`kernel`, one
/// input channel's), the thresholds `thr`. The shape of nearly every conv1 input, compiled
/// with its sizes known so that the rows are unrolled, the thresholds loaded once and the
/// last 4 lanes of a row taken as one half vector (`add_rows` costs about 1.7 times its
/// instructions on that shape). Returns the crossing lanes as two words, row `r`'s lanes
/// from bit `(r mod WORD_ROWS) · FIXED_RUN` of word `r / WORD_ROWS` (none set where none
/// crossed). `add_rows_fixed_scalar` is its reference.
///
/// `fresh` promises that no lane of these rows is at or above its threshold before the add
/// (see `ConvState::add_whole` for when that holds): a lane then crossed exactly where it is at
/// or above its threshold after the add, which spares the compare of the old potentials.
///
/// With `INLINE` the AVX2 body is inlined into the caller, which should then be compiled for
/// AVX2 (`Avx2::vectorize`) for it to run as vectors; without, it is called.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn add_rows_fixed<const INLINE: bool>(
    avx2: Avx2,
    pot: &mut [f32],
    p_stride: usize,
    kernel: &[f32; FIXED_KERNEL],
    thr: &[f32; FIXED_RUN],
    fresh: bool,
) -> [u64; 2] {
    assert!(
        pot.len() >= (FIXED_ROWS - 1) * p_stride + FIXED_RUN,
        "rows inside the layer"
    );
    #[cfg(target_arch = "x86_64")]
    {
        let _ = avx2;
        let (a, b) = if INLINE {
            // SAFETY: the rows are inside `pot` (asserted above), the kernel's and thresholds'
            // lengths are their types', and the token proves AVX2.
            unsafe { x86::add_rows_fixed_body(pot.as_mut_ptr(), p_stride, kernel, thr, fresh) }
        } else {
            // SAFETY: as above.
            unsafe { x86::add_rows_fixed_avx2(pot.as_mut_ptr(), p_stride, kernel, thr, fresh) }
        };
        [a, b]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (pot, p_stride, kernel, thr, fresh);
        match avx2.0 {}
    }
}

/// The scalar version of `add_rows_fixed` (the same words, where `fresh` holds).
#[cfg(test)]
pub(crate) fn add_rows_fixed_scalar(
    pot: &mut [f32],
    p_stride: usize,
    kernel: &[f32; FIXED_KERNEL],
    thr: &[f32; FIXED_RUN],
) -> [u64; 2] {
    let mut words = [0; 2];
    for r in 0..FIXED_ROWS {
        let (p, k) = (r * p_stride, (FIXED_ROWS - 1 - r) * FIXED_RUN);
        let mut bytes = [0u8; 4];
        let w = &kernel[k..k + FIXED_RUN];
        add_detect_scalar(&mut pot[p..p + FIXED_RUN], w, thr, &mut bytes, 0);
        let mask = u64::from(u32::from_le_bytes(bytes));
        words[r / WORD_ROWS] |= mask << (r % WORD_ROWS * FIXED_RUN);
    }
    words
}

/// The minimum of each of the four unsigned 16-bit lanes of `a` and `b` (SSE2, part of
/// x86-64, where there is one instruction for it).
#[inline]
pub(crate) fn min_u16x4(a: u64, b: u64) -> u64 {
    #[cfg(target_arch = "x86_64")]
    {
        x86::min_u16x4(a, b)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        min_u16x4_scalar(a, b)
    }
}

/// The scalar version of `min_u16x4`.
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
pub(crate) fn min_u16x4_scalar(a: u64, b: u64) -> u64 {
    let lane = |v: u64, k: u32| (v >> (16 * k)) & 0xffff;
    (0..4).fold(0, |m, k| m | lane(a, k).min(lane(b, k)) << (16 * k))
}

/// Values that `zero_all` stores at once.
const ZERO_ALL_BLOCK: usize = 32;

/// Zero all of `buf`: what `fill(0)` does, in vector stores of 32 values (AVX2 where the CPU
/// has it) rather than the `memset` call that `fill` becomes, whose `rep stos` costs one
/// instruction per byte for a layer's worth (conv2's 138 KB of potentials).
#[inline]
pub(crate) fn zero_all<T: Copy + Default>(avx2: Option<Avx2>, buf: &mut [T]) {
    match avx2 {
        Some(avx2) => avx2.vectorize(
            #[inline(always)]
            move || zero_all_body(buf),
        ),
        None => zero_all_body(buf),
    }
}

/// The loop of `zero_all`, inlined into each of its compilations.
#[allow(clippy::inline_always)]
#[inline(always)]
fn zero_all_body<T: Copy + Default>(buf: &mut [T]) {
    // A block of zeros the compiler cannot see are zeros, so that it does not turn the loop
    // back into `memset`.
    let zeros = std::hint::black_box([T::default(); ZERO_ALL_BLOCK]);
    let mut blocks = buf.chunks_exact_mut(ZERO_ALL_BLOCK);
    for block in &mut blocks {
        block.copy_from_slice(&zeros);
    }
    blocks.into_remainder().fill(T::default());
}

#[cfg(test)]
mod tests;
