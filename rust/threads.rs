//! The engine's worker threads: rayon's global pool, pools of a chosen size, and `fork`.
//!
//! A forked process (Python's `multiprocessing` and `concurrent.futures.ProcessPoolExecutor`
//! with the `fork` start method, Linux's default before Python 3.14, or `os.fork`) holds a
//! copy of its parent's rayon pools but none of their threads: parallel work handed to them
//! there waits forever. The Python binding therefore runs work directly only in the process
//! the engine first ran in; in any other it runs it on a pool started in that process
//! ([`pool`]), so the parent's pools are never used. The parent's pools are forgotten there,
//! not dropped: dropping one would signal threads that do not exist, under locks the fork may
//! have copied while held.
//!
//! `note_process`, `in_live_pool` and `cap_global_threads`, the binding's side of this, are
//! crate-private: only the binding calls them (a Rust program chooses its pools itself, with
//! [`pool`] or rayon's own).

use std::mem;
use std::num::NonZeroUsize;
use std::sync::{Arc, Mutex, OnceLock};

use crate::error::{Error, Result};

/// The most worker threads a pool may have: more than any machine this runs on has cores,
/// few enough that starting them stays cheap (a count of thousands took seconds to start).
pub const MAX_THREADS: usize = 256;

/// Worker pools kept between calls; asking for another count drops the least recently used.
const KEPT_POOLS: usize = 2;

/// The pools of a chosen size, with the process they were started in.
struct Kept {
    pid: u32,
    /// Least recently used first.
    pools: Vec<(usize, Arc<rayon::ThreadPool>)>,
}

static KEPT: Mutex<Kept> = Mutex::new(Kept {
    pid: 0,
    pools: Vec::new(),
});

/// The process the engine first ran in (set by `note_process` or the first `in_live_pool`).
///
/// Those two and `cap_global_threads` are the binding's, not the crate's API:
///
/// ```compile_fail,E0603
/// uavsnn::threads::note_process();
/// ```
///
/// ```compile_fail,E0603
/// let _ = uavsnn::threads::in_live_pool(|| ());
/// ```
///
/// ```compile_fail,E0603
/// let _ = uavsnn::threads::cap_global_threads();
/// ```
static FIRST_PROCESS: OnceLock<u32> = OnceLock::new();

/// Note the current process as the one whose rayon global pool [`in_live_pool`] may use. The
/// Python binding calls it when the module loads, before any work; a later call changes
/// nothing. Crate-private: only the binding calls it.
#[cfg_attr(not(feature = "python"), allow(dead_code))]
pub(crate) fn note_process() {
    FIRST_PROCESS.get_or_init(std::process::id);
}

/// Run `f`, whose parallel work runs on the pool it is called in, where that work has live
/// threads: on rayon's global pool in the process the engine first ran in; in a forked child,
/// on a pool of this process of as many workers as rayon's global pool takes there
/// ([`global_threads`]: `RAYON_NUM_THREADS`, else one per core).
///
/// # Errors
///
/// [`Error::Internal`] when a forked child cannot start its pool.
///
/// Crate-private: only the binding calls it.
#[cfg_attr(not(feature = "python"), allow(dead_code))]
pub(crate) fn in_live_pool<T: Send>(f: impl FnOnce() -> T + Send) -> Result<T> {
    let pid = std::process::id();
    if *FIRST_PROCESS.get_or_init(|| pid) == pid {
        return Ok(f());
    }
    Ok(pool(global_threads())?.install(f))
}

/// The workers rayon's global pool takes in this process: `RAYON_NUM_THREADS` when it is a
/// positive whole number (at most [`MAX_THREADS`], as the Python binding caps it), else one
/// per core ([`cores`]). A forked child's pool is sized so, so that `RAYON_NUM_THREADS=1` keeps
/// a pool of forked workers from taking every core each.
pub fn global_threads() -> usize {
    threads_for(std::env::var("RAYON_NUM_THREADS").ok().as_deref())
}

/// [`global_threads`] for the value `asked` of `RAYON_NUM_THREADS`.
fn threads_for(asked: Option<&str>) -> usize {
    match asked.and_then(|v| v.parse::<usize>().ok()) {
        Some(n) if n > 0 => n.min(MAX_THREADS),
        _ => cores(),
    }
}

/// One worker per core the system reports (1 when it reports none), at most [`MAX_THREADS`].
pub fn cores() -> usize {
    std::thread::available_parallelism()
        .map_or(1, NonZeroUsize::get)
        .min(MAX_THREADS)
}

/// A rayon pool of `n` workers of this process, started on first use and kept for later calls
/// (starting threads costs more than a small batch). At most two are kept, the most
/// recently used: a pool dropped here ends its threads once the calls running on it return.
///
/// # Errors
///
/// [`Error::InvalidParameter`] for `n` outside `1..=`[`MAX_THREADS`]; [`Error::Internal`] when the
/// pools' lock is poisoned or the threads cannot start.
pub fn pool(n: usize) -> Result<Arc<rayon::ThreadPool>> {
    if !(1..=MAX_THREADS).contains(&n) {
        return Err(Error::param(
            "threads",
            format!("a pool has 1 to MAX_THREADS ({MAX_THREADS}) workers, got {n}"),
        ));
    }
    let mut kept = KEPT
        .lock()
        .map_err(|_| Error::Internal("thread pools poisoned".into()))?;
    let pid = std::process::id();
    if kept.pid != pid {
        // Pools of a parent process (this one is a forked child): their threads are not here.
        mem::forget(mem::take(&mut kept.pools));
        kept.pid = pid;
    }
    take_pool(&mut kept.pools, n, KEPT_POOLS)
}

/// The pool of `n` workers in `pools` (most recently used last), started if missing, keeping
/// at most `keep` pools.
fn take_pool(
    pools: &mut Vec<(usize, Arc<rayon::ThreadPool>)>,
    n: usize,
    keep: usize,
) -> Result<Arc<rayon::ThreadPool>> {
    if let Some(i) = pools.iter().position(|(m, _)| *m == n) {
        let entry = pools.remove(i);
        let p = Arc::clone(&entry.1);
        pools.push(entry);
        return Ok(p);
    }
    let p = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| Error::Internal(format!("cannot start {n} threads: {e}")))?,
    );
    if pools.len() >= keep {
        pools.remove(0);
    }
    pools.push((n, Arc::clone(&p)));
    Ok(p)
}

/// Size rayon's global pool at [`MAX_THREADS`] when the environment asks for more
/// (`RAYON_NUM_THREADS`, read by rayon as a whole number): 2,000 threads took seconds to start
/// for a call of milliseconds, and 100,000 failed to start, after which every parallel call
/// panicked. Any other value is left to rayon (0, or a value that is not a number: one worker
/// per core). Returns whether it capped the pool; does nothing once the global pool is built.
/// Crate-private: the binding calls it when the module loads; a Rust program sizes rayon's
/// global pool itself.
#[cfg_attr(not(feature = "python"), allow(dead_code))]
pub(crate) fn cap_global_threads() -> bool {
    let asked = std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok());
    asked.is_some_and(|n| n > MAX_THREADS)
        && rayon::ThreadPoolBuilder::new()
            .num_threads(MAX_THREADS)
            .build_global()
            .is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pool_has_one_to_max_threads_workers() {
        for n in [0, MAX_THREADS + 1, usize::MAX] {
            let err = pool(n).unwrap_err();
            assert!(matches!(err, Error::InvalidParameter { .. }), "{n}: {err}");
            assert!(err.to_string().contains("MAX_THREADS"), "{err}");
        }
        assert_eq!(pool(1).unwrap().current_num_threads(), 1);
    }

    #[test]
    fn a_forked_childs_pool_takes_what_rayon_would() {
        assert_eq!(threads_for(Some("1")), 1);
        assert_eq!(threads_for(Some("3")), 3);
        assert_eq!(threads_for(Some("100000")), MAX_THREADS);
        for unset in [None, Some("0"), Some("many"), Some("-2"), Some("")] {
            assert_eq!(threads_for(unset), cores(), "{unset:?}");
        }
    }

    #[test]
    fn pools_are_reused_and_bounded() {
        let mut pools = Vec::new();
        let first = take_pool(&mut pools, 2, 2).unwrap();
        assert!(Arc::ptr_eq(&first, &take_pool(&mut pools, 2, 2).unwrap()));
        for n in [3, 2, 4, 5, 6, 5] {
            let p = take_pool(&mut pools, n, 2).unwrap();
            assert_eq!(p.current_num_threads(), n);
            assert!(pools.len() <= 2);
            assert_eq!(pools.last().map(|e| e.0), Some(n));
        }
        let kept: Vec<usize> = pools.iter().map(|e| e.0).collect();
        assert_eq!(kept, [6, 5]);
        // The pool of 2 was dropped from the list: asking again starts another.
        assert!(!Arc::ptr_eq(&first, &take_pool(&mut pools, 2, 2).unwrap()));
    }

    #[test]
    fn work_runs_directly_in_the_first_process() {
        note_process();
        // Not on a pool of this module: the caller's thread, outside any pool.
        let on = in_live_pool(rayon::current_thread_index).unwrap();
        assert_eq!(on, None);
    }
}
