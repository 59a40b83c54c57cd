//! Generator tests: counts as announced, watertightness (shared edges share vertices),
//! closed and nested engine parts, closed and outward parts of the exposed engine and the
//! truss within their budgets and bounds, determinism, and a zero-copy read back through `Mesh`.

use std::collections::HashMap;

use super::engine::{Engine, casing_inside};
use super::exposed::ExposedEngine;
use super::grid::BunnyGrid;
use super::shapes::{Part, Shape, UNROTATED, axes_along};
use super::subdivide::SubdividedMesh;
use super::truss::Truss;
use super::*;
use crate::ooc::Mesh;
use crate::test_kit::bunny::bunny;

fn collect(model: &dyn Model) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (mut v, mut t) = (Vec::new(), Vec::new());
    model
        .vertices(&mut |p| {
            v.push(p);
            Ok(())
        })
        .unwrap();
    model
        .triangles(&mut |x| {
            t.push(x);
            Ok(())
        })
        .unwrap();
    assert_eq!(v.len() as u64, model.vertex_count());
    assert_eq!(t.len() as u64, model.triangle_count());
    (v, t)
}

/// Directed-edge use counts.
fn directed_edges(triangles: &[[u32; 3]]) -> HashMap<(u32, u32), u32> {
    let mut edges = HashMap::new();
    for t in triangles {
        for e in 0..3 {
            *edges.entry((t[e], t[(e + 1) % 3])).or_insert(0) += 1;
        }
    }
    edges
}

/// Undirected edges used by exactly one triangle: the mesh's boundary.
fn boundary_edges(triangles: &[[u32; 3]]) -> usize {
    let mut count: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    count.values().filter(|&&c| c == 1).count()
}

#[test]
fn subdivision_shares_edge_points_and_keeps_the_topology() {
    let source = bunny();
    let source_triangles: Vec<[u32; 3]> = (0..source.triangle_count())
        .map(|t| source.triangle(t))
        .collect();
    let source_boundary = boundary_edges(&source_triangles);
    for k in [1, 2, 3] {
        let model = SubdividedMesh::new(&source, k);
        let (vertices, triangles) = collect(&model);
        assert_eq!(
            triangles.len() as u64,
            u64::from(source.triangle_count()) * u64::from(k * k)
        );
        assert!(
            triangles
                .iter()
                .flatten()
                .all(|&i| (i as usize) < vertices.len())
        );
        // Duplicated split points would open a boundary along every source edge; shared ones
        // split each source boundary edge into exactly k boundary edges.
        assert_eq!(
            boundary_edges(&triangles),
            k as usize * source_boundary,
            "k={k}"
        );
        // Every vertex is used: no orphans from a numbering mistake.
        let mut used = vec![false; vertices.len()];
        for &i in triangles.iter().flatten() {
            used[i as usize] = true;
        }
        let unused = used.iter().filter(|&&u| !u).count();
        let source_unused = {
            let mut u = vec![false; source.vertex_count() as usize];
            source_triangles
                .iter()
                .flatten()
                .for_each(|&i| u[i as usize] = true);
            u.iter().filter(|&&x| !x).count()
        };
        assert_eq!(unused, source_unused, "k={k}");
        // The relief is small: source vertices move by at most the amplitude.
        let b = source.bounds();
        let diagonal = super::subdivide::length(super::subdivide::sub(b.max, b.min));
        for v in (0..source.vertex_count()).step_by(97) {
            let moved = super::subdivide::length(super::subdivide::sub(
                vertices[v as usize],
                source.position(v),
            ));
            assert!(moved <= 0.0041 * diagonal, "vertex {v} moved {moved}");
        }
    }
    assert_eq!(SubdividedMesh::factor_for(&source, 20_000_000), 14);
    assert_eq!(SubdividedMesh::factor_for(&source, 10), 1);
}

/// Without relief, `k = 2` is one level of midpoint subdivision: the source vertices unmoved,
/// then one vertex per source edge at exactly `½(a + b)`.
#[test]
fn subdivision_without_relief_is_midpoint_subdivision() {
    let source = bunny();
    let (vertices, triangles) = collect(&SubdividedMesh::without_relief(&source, 2));
    let mut midpoints = HashMap::new();
    for t in 0..source.triangle_count() {
        let tri = source.triangle(t);
        for e in 0..3 {
            let (a, b) = (tri[e], tri[(e + 1) % 3]);
            let (p, q) = (source.position(a), source.position(b));
            let mid = [0, 1, 2].map(|k| (0.5 * (p[k] + q[k])).to_bits());
            midpoints.insert((a.min(b), a.max(b)), mid);
        }
    }
    let v = source.vertex_count() as usize;
    assert_eq!(vertices.len(), v + midpoints.len());
    assert_eq!(triangles.len(), 4 * source.triangle_count() as usize);
    for (i, p) in vertices[..v].iter().enumerate() {
        assert_eq!(*p, source.position(i as u32), "source vertex {i}");
    }
    let expected: std::collections::HashSet<[u32; 3]> = midpoints.into_values().collect();
    for (i, p) in vertices[v..].iter().enumerate() {
        assert!(
            expected.contains(&p.map(f32::to_bits)),
            "edge point {i}: {p:?}"
        );
    }
}

#[test]
fn engine_parts_are_closed_outward_and_nested() {
    let engine = Engine::new(200_000);
    let (vertices, triangles) = collect(&engine);
    assert!(engine.part_count() > 20, "{} parts", engine.part_count());
    let n = triangles.len() as f64;
    assert!((0.8..1.25).contains(&(n / 200_000.0)), "{n} triangles");
    // Closed and consistently oriented: each directed edge once, its reverse once.
    let edges = directed_edges(&triangles);
    for (&(a, b), &count) in &edges {
        assert_eq!(count, 1, "edge {a}-{b} used {count} times in one direction");
        assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
    }
    // Outward: the signed volume is positive (the parts do not overlap).
    let volume: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize].map(f64::from));
            (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))
                / 6.0
        })
        .sum();
    assert!(volume > 0.0, "volume {volume}");
    // Nested: the casing comes first; everything after it is strictly inside it, and
    // everything after the housing strictly inside the housing.
    let casing = engine_part_vertices(&Engine::new(200_000), 1);
    let housing_end = engine_part_vertices(&Engine::new(200_000), 2);
    for (v, &p) in vertices.iter().enumerate().skip(casing) {
        assert!(
            casing_inside(p, 1.0) < 0.99,
            "vertex {v} {p:?} outside the casing"
        );
        if v >= housing_end {
            assert!(
                casing_inside(p, 0.9) < 0.99,
                "vertex {v} {p:?} outside the housing"
            );
        }
    }
}

/// Vertices in the first `parts` parts of an engine.
fn engine_part_vertices(engine: &Engine, parts: usize) -> usize {
    engine.part_vertex_counts().iter().take(parts).sum::<u64>() as usize
}

#[test]
fn bunny_grid_places_separate_copies() {
    let source = bunny();
    assert_eq!(BunnyGrid::copies_for(&source, 1_000_000), 10);
    let grid = BunnyGrid::new(&source, 5);
    let (vertices, triangles) = collect(&grid);
    assert_eq!(vertices.len(), 5 * source.vertex_count() as usize);
    let per_copy = source.vertex_count() as usize;
    // Copies do not overlap on the floor: their x–z footprints are disjoint.
    let footprint = |c: usize| {
        let mut lo = [f32::MAX; 2];
        let mut hi = [f32::MIN; 2];
        for p in &vertices[c * per_copy..(c + 1) * per_copy] {
            lo = [lo[0].min(p[0]), lo[1].min(p[2])];
            hi = [hi[0].max(p[0]), hi[1].max(p[2])];
        }
        (lo, hi)
    };
    for a in 0..5 {
        for b in a + 1..5 {
            let ((la, ha), (lb, hb)) = (footprint(a), footprint(b));
            let apart = ha[0] < lb[0] || hb[0] < la[0] || ha[1] < lb[1] || hb[1] < la[1];
            assert!(apart, "copies {a} and {b} overlap");
        }
    }
    // Copy c's triangles are the source's, shifted by c × vertices.
    let t0 = source.triangle_count() as usize;
    assert_eq!(
        triangles[3 * t0 + 17],
        source.triangle(17).map(|i| i + 3 * per_copy as u32)
    );
}

#[test]
fn written_ply_is_deterministic_and_opens_zero_copy() {
    let source = bunny();
    let write = || {
        let mut bytes = Vec::new();
        write_ply(&mut bytes, &SubdividedMesh::new(&source, 2), "test").unwrap();
        bytes
    };
    let bytes = write();
    assert_eq!(bytes, write());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub.ply");
    std::fs::write(&path, &bytes).unwrap();
    let mesh = Mesh::open(&path).unwrap();
    assert!(mesh.is_mapped());
    let model = SubdividedMesh::new(&source, 2);
    let (vertices, triangles) = collect(&model);
    assert_eq!(mesh.triangle_count() as usize, triangles.len());
    assert_eq!(mesh.triangle(12345), triangles[12345]);
    assert_eq!(mesh.position(54321), vertices[54321]);
}

/// Checks that every part (a run of `part_vertices` vertices, its triangles indexing only
/// them) is closed, consistently oriented and outward, and that no triangle has zero area.
fn assert_closed_outward_parts(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    part_vertices: &[u64],
) {
    assert_eq!(part_vertices.iter().sum::<u64>(), vertices.len() as u64);
    let starts: Vec<u64> = part_vertices
        .iter()
        .scan(0, |start, &n| {
            let s = *start;
            *start += n;
            Some(s)
        })
        .collect();
    let part_of = |i: u32| starts.partition_point(|&s| s <= u64::from(i)) - 1;
    let edges = directed_edges(triangles);
    for (&(a, b), &count) in &edges {
        assert_eq!(count, 1, "edge {a}-{b} used {count} times in one direction");
        assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
    }
    let mut volumes = vec![0.0f64; part_vertices.len()];
    for (n, t) in triangles.iter().enumerate() {
        assert!(
            t.iter().all(|&i| (i as usize) < vertices.len()),
            "triangle {n} {t:?} out of range"
        );
        let part = part_of(t[0]);
        assert!(
            t.iter().all(|&i| part_of(i) == part),
            "triangle {n} spans parts"
        );
        // Relative to the part's first vertex, which keeps the sums small and exact enough.
        let origin = vertices[starts[part] as usize].map(f64::from);
        let [a, b, c] = t.map(|i| {
            let p = vertices[i as usize].map(f64::from);
            [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]]
        });
        let (u, v) = (
            [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
            [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
        );
        let normal = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let twice_area = (normal[0].powi(2) + normal[1].powi(2) + normal[2].powi(2)).sqrt();
        assert!(twice_area > 1e-12, "triangle {n} {t:?} has zero area");
        volumes[part] += (a[0] * normal[0] + a[1] * normal[1] + a[2] * normal[2]) / 6.0;
    }
    for (part, volume) in volumes.iter().enumerate() {
        assert!(*volume > 0.0, "part {part} has volume {volume}");
    }
}

fn assert_within(vertices: &[[f32; 3]], lo: [f32; 3], hi: [f32; 3]) {
    for (v, p) in vertices.iter().enumerate() {
        assert!(
            (0..3).all(|a| lo[a] <= p[a] && p[a] <= hi[a]),
            "vertex {v} {p:?} outside {lo:?}..{hi:?}"
        );
    }
}

fn ply_bytes(model: &dyn Model) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_ply(&mut bytes, model, "test").unwrap();
    bytes
}

#[test]
fn shapes_for_assemblies_are_closed_and_outward() {
    let tilted = axes_along([1.0, 2.0, -0.5], 0.7);
    let shapes = [
        Shape::Cuboid {
            half: [0.5, 0.2, 0.01],
            steps: [3, 2, 1],
        },
        Shape::Cuboid {
            half: [0.3, 0.4, 0.5],
            steps: [2, 3, 4],
        },
        Shape::Prism {
            radius: 0.1,
            half_length: 1.0,
            sides: 8,
            segments: 3,
        },
        Shape::Tube {
            outer: 0.3,
            inner: 0.2,
            half_length: 0.5,
            sides: 9,
            segments: 2,
        },
    ];
    for shape in shapes {
        for axes in [UNROTATED, tilted] {
            let part = Part {
                shape,
                axes,
                centre: [1.0, -2.0, 0.5],
            };
            let mut vertices = Vec::new();
            part.vertices(&mut |p| {
                vertices.push(p);
                Ok(())
            })
            .unwrap();
            let mut triangles = Vec::new();
            part.triangles(0, &mut |t| {
                triangles.push(t);
                Ok(())
            })
            .unwrap();
            assert_eq!(vertices.len() as u64, part.vertex_count(), "{shape:?}");
            assert_eq!(triangles.len() as u64, part.triangle_count(), "{shape:?}");
            assert_closed_outward_parts(&vertices, &triangles, &[part.vertex_count()]);
        }
    }
    // A 3 × 2 × 1 box: 12 lattice points on each of its two layers, none inside.
    let part = Part {
        shape: shapes[0],
        axes: UNROTATED,
        centre: [0.0; 3],
    };
    assert_eq!(part.vertex_count(), 24);
    assert_eq!(part.triangle_count(), 4 * (6 + 2 + 3));
}

#[test]
fn exposed_engine_has_closed_parts_within_budget_and_bounds() {
    for budget in [20_000, 40_000, 60_000] {
        let model = ExposedEngine::new(budget);
        let (vertices, triangles) = collect(&model);
        let n = triangles.len() as u64;
        assert!(
            n <= budget && n as f64 >= 0.95 * budget as f64,
            "{n} triangles for {budget}"
        );
        assert!(model.part_count() > 100, "{} parts", model.part_count());
        assert_closed_outward_parts(&vertices, &triangles, &model.part_vertex_counts());
        assert_within(&vertices, [-2.0, -1.2, -1.2], [2.0, 1.1, 1.2]);
    }
    // Below its fewest triangles it stays whole, at its coarsest.
    let coarsest = ExposedEngine::new(1);
    assert!((3_000..8_000).contains(&coarsest.triangle_count()));
    assert_eq!(
        coarsest.part_count(),
        ExposedEngine::new(40_000).part_count()
    );
}

#[test]
fn truss_has_closed_parts_within_budget_and_bounds() {
    for (budget, cells) in [(20_000, 5), (40_000, 6), (60_000, 7)] {
        let model = Truss::new(budget);
        assert_eq!(model.cells_per_side(), cells);
        let (vertices, triangles) = collect(&model);
        let n = triangles.len() as u64;
        assert!(
            n <= budget && n as f64 >= 0.95 * budget as f64,
            "{n} triangles for {budget}"
        );
        // Nodes and edge beams at least.
        let lattice = (cells + 1) * (cells + 1);
        assert!(model.part_count() > (lattice * (cells + 1) + 3 * cells * lattice) as usize);
        assert_closed_outward_parts(&vertices, &triangles, &model.part_vertex_counts());
        assert_within(&vertices, [-2.1; 3], [2.1; 3]);
    }
    let coarsest = Truss::new(1);
    assert_eq!(coarsest.cells_per_side(), 2);
    assert!(coarsest.triangle_count() < 2_000);
}

#[test]
fn exposed_engine_and_truss_are_deterministic() {
    let engine = ply_bytes(&ExposedEngine::new(30_000));
    assert_eq!(engine, ply_bytes(&ExposedEngine::new(30_000)));
    let truss = ply_bytes(&Truss::new(30_000));
    assert_eq!(truss, ply_bytes(&Truss::new(30_000)));
    assert_ne!(engine, truss);
}
