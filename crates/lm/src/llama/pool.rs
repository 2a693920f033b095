//! Work split over candle's worker pool by disjoint slices of one output buffer: the one
//! mechanism the Q4_1 matmul and attention share.

use std::ops::Range;
use std::sync::{Mutex, PoisonError};

/// Runs `work(scratch, i, chunk)` for every `chunk_len`-long chunk `i` of `out` (the last may
/// be shorter): on candle's barrier pool when `parallel`, else on this thread. Each chunk is
/// written by exactly one call, so results do not depend on the thread count; `scratch` makes a
/// worker's own scratch space, once per range of chunks it takes from the pool.
pub(crate) fn for_each_chunk<S>(
    out: &mut [f32],
    chunk_len: usize,
    parallel: bool,
    scratch: impl Fn() -> S + Sync,
    work: impl Fn(&mut S, usize, &mut [f32]) + Sync,
) {
    // A lock per chunk hands each `&mut` slice to whichever worker takes its index; it is never
    // contended (one index, one taker).
    let chunks: Vec<Mutex<&mut [f32]>> = out.chunks_mut(chunk_len).map(Mutex::new).collect();
    let run = |range: Range<usize>| {
        let mut space = scratch();
        for i in range {
            let mut chunk = chunks[i].lock().unwrap_or_else(PoisonError::into_inner);
            work(&mut space, i, &mut chunk);
        }
    };
    if parallel {
        candle_core::utils::barrier_pool().execute_chunked(chunks.len(), run);
    } else {
        run(0..chunks.len());
    }
}
