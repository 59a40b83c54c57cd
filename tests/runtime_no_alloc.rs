//! **Invariant** check: the reader never allocates. A counting global allocator watches
//! `Pvis::parse`, `query`, `view_row`, streaming and expanded queries, and iterating the answer.
#![cfg(feature = "bake")]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use patchvis::format::{BakeContents, encode};
use patchvis::runtime::Pvis;
use patchvis::sampler::{SamplingParams, VisibilityMatrix};
use patchvis::tiling::Patch;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the caller upholds `GlobalAlloc::alloc`'s contract, which we pass on.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn parse_query_streaming_expanded_and_iteration_allocate_nothing() {
    let params = SamplingParams {
        level: 2,
        resolution: 64,
        fov_deg: 40.0,
        center: [0.0; 3],
        radius: 1.0,
    };
    let patches: Vec<Patch> = (0..100)
        .map(|i| Patch {
            first: i,
            count: 1,
            area: 1.0,
            center: [0.0; 3],
            radius: 0.1,
            cone_axis: [0.0, 1.0, 0.0],
            cone_cos: -1.0,
        })
        .collect();
    let mut matrix = VisibilityMatrix::new(66, 100);
    for v in 0..66 {
        matrix.set(v, v);
        matrix.set(v, 99 - v);
    }
    let bytes = encode(&BakeContents {
        sampling: &params,
        triangle_count: 100,
        patches: &patches,
        visibility: &matrix,
    });
    let mut scratch = vec![0u64; 2];
    let probe = Pvis::parse(&bytes).unwrap();
    let mut stream_scratch = vec![0u64; probe.scratch_bound()];
    let mut table = vec![0u64; probe.expanded_bound()];
    let mut row = vec![0u64; probe.row_words()];

    let before = ALLOCATIONS.load(Ordering::SeqCst);
    let pvis = Pvis::parse(&bytes).unwrap();
    let mut seen = 0u32;
    let mut triangles = 0u32;
    for eye in [[5.0, 1.0, -2.0], [0.0, 0.0, 0.0], [-3.0, 9.0, 0.5]] {
        let vis = pvis.query(eye, &mut scratch);
        seen += vis.patches().count() as u32;
        triangles += pvis.ranges(&vis).map(|(_, count)| count).sum::<u32>();
        assert!(vis.contains(vis.patches().next().unwrap()));
    }
    pvis.view_row(40, &mut row);
    let mut streaming = pvis.streaming(&mut stream_scratch);
    let mut expanded = pvis.expand(&mut table);
    for i in 0..200 {
        let a = i as f32 * 0.05;
        let eye = [5.0 * a.cos(), 1.0, 5.0 * a.sin()];
        let s = streaming.query(eye);
        seen += s.count();
        let e = expanded.query(eye);
        seen += e.count();
        triangles += 2 * e.count();
        assert!(e.patches().all(|p| !pvis.backfacing(p, eye) || p < 100));
    }
    let after = ALLOCATIONS.load(Ordering::SeqCst);

    assert_eq!(after - before, 0, "the reader allocated");
    assert!(seen >= 3 && triangles == seen);
}
