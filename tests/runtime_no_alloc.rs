//! **Invariant** check: the reader never allocates. The library's counting global allocator
//! watches `Pvis::parse`, `query`, `view_row`, streaming and expanded queries, and iterating
//! the answer, on a version-4 file, a version-5 file with sampling shells and a version-6 file
//! with a far band too (eyes in every band). It counts per thread, so the harness's threads,
//! which may allocate at any time, do not disturb the count of the test's own.
#![cfg(feature = "bake")]

use patchvis::format::{BakeContents, ShellRows, encode};
use patchvis::heap;
use patchvis::runtime::{DepthRange, Frustum, Pvis};
use patchvis::sampler::{SamplingParams, VisibilityMatrix};
use patchvis::tiling::Patch;

#[global_allocator]
static ALLOC: heap::CountingAlloc = heap::CountingAlloc;

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
    // Near shells of levels 2 and 1 inside the sampling distance (2.92), far ones outside.
    let mut near = VisibilityMatrix::new(18, 100);
    for v in 0..18 {
        for p in (v..100).step_by(7) {
            near.set(v, p);
        }
    }
    // Far shells (version 6) at 40 and 6, then near ones at 2 and 1.3.
    let shells = [
        ShellRows {
            distance: 40.0,
            visibility: &matrix,
        },
        ShellRows {
            distance: 6.0,
            visibility: &near,
        },
        ShellRows {
            distance: 2.0,
            visibility: &matrix,
        },
        ShellRows {
            distance: 1.3,
            visibility: &near,
        },
    ];
    for shells in [&shells[..0], &shells[2..], &shells[..]] {
        let bytes = encode(&BakeContents {
            sampling: &params,
            triangle_count: 100,
            patches: &patches,
            visibility: &matrix,
            shells,
            reach: 0.0,
        });
        assert_eq!(
            Pvis::parse(&bytes).unwrap().shell_count() as usize,
            shells.len()
        );
        reader_allocates_nothing(&bytes);
    }
}

/// Every reader call on `bytes` under the counting allocator.
fn reader_allocates_nothing(bytes: &[u8]) {
    let mut scratch = vec![0u64; 2];
    let probe = Pvis::parse(bytes).unwrap();
    let mut stream_scratch = vec![0u64; probe.scratch_bound()];
    let mut table = vec![0u64; probe.expanded_bound()];
    let mut row = vec![0u64; probe.row_words()];

    let mut culled = vec![0u64; probe.row_words()];
    // A frustum looking down −Z from z = 5 (90°, 0 ≤ z ≤ w), aimed so that its side cuts.
    #[rustfmt::skip]
    let view_proj: [f32; 16] = [
        1.0, 0.0, 0.0, 0.0,
        0.0, 1.0, 0.0, 0.0,
        0.0, 0.0, -0.001, -1.0,
        -0.5, 0.0, 0.001 * 5.0 + 0.01, 5.0,
    ];

    let before = heap::allocations();
    let frustum = Frustum::from_view_projection(&view_proj, DepthRange::ZeroToOne);
    let pvis = Pvis::parse(bytes).unwrap();
    let mut seen = 0u32;
    let mut triangles = 0u32;
    for eye in [[5.0, 1.0, -2.0], [0.0, 0.0, 0.0], [-3.0, 9.0, 0.5]] {
        let vis = pvis.query(eye, &mut scratch);
        seen += vis.patches().count() as u32;
        triangles += pvis.ranges(&vis).map(|(_, count)| count).sum::<u32>();
        assert!(vis.contains(vis.patches().next().unwrap()));
    }
    pvis.view_row(40, &mut row);
    for s in 0..=pvis.shell_count() {
        seen += pvis.shell(s).views.min(1);
        pvis.shell_view_row(s, 3, &mut row);
    }
    let mut streaming = pvis.streaming(&mut stream_scratch);
    let mut expanded = pvis.expand(&mut table);
    for i in 0..200 {
        // An orbit whose radius sweeps from beyond the outermost shell to inside the
        // innermost one and back, so that every band and shell boundary is crossed.
        let a = i as f32 * 0.05;
        let r = 0.5 * 200f32.powf(0.5 * (1.0 + (a * 0.7).cos()));
        let eye = [r * a.cos(), 0.3, r * a.sin()];
        let s = streaming.query(eye);
        seen += s.count();
        let shared = expanded.query_shared(eye, &mut row).count();
        let e = expanded.query(eye);
        assert_eq!(e.count(), shared);
        seen += e.count();
        triangles += 2 * e.count();
        assert!(e.patches().all(|p| !pvis.backfacing(p, eye) || p < 100));
        let e = expanded.query_in_frustum(eye, &frustum);
        seen += e.count();
        triangles += e.count();
        let s = streaming.query_in_frustum(eye, &frustum, &mut culled);
        seen += s.count();
        triangles += s.count();
    }
    for eye in [[0.0, 0.0, 5.0], [f32::NAN, 0.0, 0.0]] {
        let vis = pvis.query_in_frustum(eye, &frustum, &mut scratch);
        seen += vis.count();
        triangles += pvis.ranges(&vis).map(|(_, count)| count).sum::<u32>();
    }
    let after = heap::allocations();

    assert!(before > 0, "the counting allocator is not installed");
    assert_eq!(after - before, 0, "the reader allocated");
    assert!(seen >= 3 && triangles + 1 + pvis.shell_count() == seen);
}
