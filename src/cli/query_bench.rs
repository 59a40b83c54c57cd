//! `patchvis query --bench N`: the median time per query of each of the reader's query modes
//! (stateless, expanded with and without a frustum, streaming), on seeded eyes at 1.5 times
//! the sampling distance (beyond it, between it and the default far band's first shell), the
//! stateless query first as the baseline.
//!
//! The sub-microsecond modes are timed [`BATCH`] queries at a time. The plain expanded query
//! and the two frustum queries run alternately, batch by batch, so that all three see the
//! same machine. Every answer is folded into a sink that the optimiser must keep.

use super::out::outln;
use super::view::LookAt;
use anyhow::Result;
use patchvis::runtime::{DepthRange, Expanded, Frustum, Pvis};
use std::time::Instant;

/// Queries per timed batch for the sub-microsecond modes: long enough to dwarf the clock's
/// own cost (~25 ns per `Instant::now`), short enough to give many samples.
const BATCH: usize = 64;

/// Queries of the stateless mode, which decodes a leaf's rows on every query.
const STATELESS_QUERIES: usize = 200;

/// The most queries `--bench` times per mode: a million is seconds of work, and each
/// query's eye and answer are kept.
pub(super) const MAX_QUERIES: u32 = 1_000_000;

/// `query --bench N`: times each mode, then prints a line per mode.
pub(super) fn bench(pvis: &Pvis<'_>, n: u32) -> Result<()> {
    let mut bench = Bench::new(pvis, n);
    let mut stateless = bench.stateless();
    // Expanded: random eyes, each usually in a new leaf.
    let t = Instant::now();
    let mut table = vec![0u64; pvis.expanded_bound()];
    let mut expanded = pvis.expand(&mut table);
    let expand_ms = t.elapsed().as_secs_f64() * 1e3;
    let mut random = bench.expanded_random(&mut expanded);
    let mut frustum = bench.expanded_frustum(&mut expanded)?;
    let mut expanded_orbit = bench.expanded_orbit(&mut expanded);
    let mut stay = bench.streaming_stay();
    let mut orbit = bench.streaming_orbit(n);
    std::hint::black_box(bench.sink);

    let s = pvis.sampling();
    outln!(
        "{} patches, level {} ({} views), VISB encoding {}; medians over {} queries per mode",
        pvis.patch_count(),
        s.level,
        s.views,
        pvis.encoding(),
        n
    )?;
    outln!(
        "  stateless Pvis::query (lock-step decode) {:>10.0} ns   (baseline; {} queries)",
        median(&mut stateless),
        stateless.len()
    )?;
    outln!(
        "  expanded query, random eyes              {:>10.0} ns   (expand once: {:.1} ms, {} KiB table)",
        median(&mut random),
        expand_ms,
        pvis.expanded_bound() * 8 / 1024
    )?;
    frustum.print(s.fov_deg)?;
    outln!(
        "  expanded query, smooth orbit             {:>10.0} ns",
        median(&mut expanded_orbit)
    )?;
    outln!(
        "  streaming, camera staying in its leaf    {:>10.0} ns   ({} KiB scratch)",
        median(&mut stay),
        pvis.scratch_bound() * 8 / 1024
    )?;
    orbit.print(n)
}

/// The eyes a bench queries and the sink its answers go to.
struct Bench<'p, 'a> {
    pvis: &'p Pvis<'a>,
    /// Where the eyes lie.
    sphere: EyeSphere,
    /// The seeded stream the eyes came from; the streaming bench draws its jitter from it.
    next: Seeded,
    /// Seeded eyes on `sphere`: `N`, at least one batch.
    eyes: Vec<[f32; 3]>,
    /// Whole batches of [`BATCH`] eyes.
    batches: usize,
    /// Every answer folded in, so that no query is optimised away.
    sink: u64,
}

impl<'p, 'a> Bench<'p, 'a> {
    /// `n` seeded eyes (at least one batch).
    fn new(pvis: &'p Pvis<'a>, n: u32) -> Self {
        let s = pvis.sampling();
        let sphere = EyeSphere {
            center: s.center,
            radius: 1.5 * s.distance,
        };
        let mut next = Seeded::new(0x5EED);
        let mut eyes = Vec::new();
        for _ in 0..n.max(BATCH as u32) {
            let d = [next.next(), next.next(), next.next()];
            eyes.push(sphere.eye(d));
        }
        let batches = eyes.len() / BATCH;
        Bench {
            pvis,
            sphere,
            next,
            eyes,
            batches,
            sink: 0,
        }
    }

    /// Stateless `Pvis::query`, lock-step decode of the leaf's corners (the baseline): ns per
    /// query, one query at a time, over the first [`STATELESS_QUERIES`] eyes.
    fn stateless(&mut self) -> Vec<f64> {
        let mut scratch = vec![0u64; self.pvis.scratch_words()];
        let count = self.eyes.len().min(STATELESS_QUERIES);
        self.eyes[..count]
            .iter()
            .map(|&eye| {
                let t = Instant::now();
                let answer = self.pvis.query(eye, &mut scratch).count();
                self.sink = self.sink.wrapping_add(u64::from(answer));
                t.elapsed().as_nanos() as f64
            })
            .collect()
    }

    /// The expanded query on the random eyes: ns per query, a batch at a time.
    fn expanded_random(&mut self, expanded: &mut Expanded<'_, '_>) -> Vec<f64> {
        (0..self.batches)
            .map(|b| {
                let t = Instant::now();
                for &eye in &self.eyes[b * BATCH..(b + 1) * BATCH] {
                    self.sink = self.sink.wrapping_add(expanded.query(eye).bits()[0]);
                }
                t.elapsed().as_nanos() as f64 / BATCH as f64
            })
            .collect()
    }

    /// The expanded query with a frustum, alternated batch by batch with the plain query so
    /// that both see the same machine: from each eye a camera looking at the model's centre
    /// (the frustum holds the whole model) and one aimed 1.5 radii off it, so the frustum's
    /// side cuts the model.
    fn expanded_frustum(&mut self, expanded: &mut Expanded<'_, '_>) -> Result<FrustumTimes> {
        let s = self.pvis.sampling();
        let aimed = |eye: [f32; 3], off: f32| {
            let d = [0, 1, 2].map(|i| s.center[i] - eye[i]);
            let side = [d[2], 0.0, -d[0]];
            let len = (side[0] * side[0] + side[2] * side[2]).sqrt().max(1e-30);
            let target = [0, 1, 2].map(|i| s.center[i] + side[i] / len * off * s.radius);
            LookAt {
                eye,
                target,
                fov_deg: s.fov_deg,
                aspect: 1.0,
                near: None,
                far: None,
            }
            .view_projection()
        };
        let mut matrices = Vec::with_capacity(2 * self.eyes.len());
        for &eye in &self.eyes {
            matrices.push(aimed(eye, 0.0)?);
            matrices.push(aimed(eye, 1.5)?);
        }
        let t = Instant::now();
        let frusta: Vec<Frustum> = matrices
            .iter()
            .map(|m| Frustum::from_view_projection(m, DepthRange::NegativeOneToOne))
            .collect();
        let mut times = FrustumTimes {
            build_ns: t.elapsed().as_nanos() as f64 / frusta.len() as f64,
            plain: Vec::new(),
            centred: Vec::new(),
            cut: Vec::new(),
            kept: 0,
            total: 0,
        };
        let eyes = &self.eyes;
        for b in 0..self.batches {
            let range = b * BATCH..(b + 1) * BATCH;
            let t = Instant::now();
            for &eye in &eyes[range.clone()] {
                self.sink = self.sink.wrapping_add(expanded.query(eye).bits()[0]);
            }
            times
                .plain
                .push(t.elapsed().as_nanos() as f64 / BATCH as f64);
            for (k, samples) in [(0, &mut times.centred), (1, &mut times.cut)] {
                let t = Instant::now();
                for i in range.clone() {
                    let v = expanded.query_in_frustum(eyes[i], &frusta[2 * i + k]);
                    self.sink = self.sink.wrapping_add(v.bits()[0]);
                }
                samples.push(t.elapsed().as_nanos() as f64 / BATCH as f64);
            }
            for i in range {
                times.total += u64::from(expanded.query(eyes[i]).count());
                times.kept += u64::from(
                    expanded
                        .query_in_frustum(eyes[i], &frusta[2 * i + 1])
                        .count(),
                );
            }
        }
        Ok(times)
    }

    /// The expanded query along the smooth orbit: mostly the same leaf, sometimes a
    /// neighbour; ns per query, a batch at a time.
    fn expanded_orbit(&mut self, expanded: &mut Expanded<'_, '_>) -> Vec<f64> {
        let sphere = self.sphere;
        (0..self.batches as u32)
            .map(|b| {
                let t = Instant::now();
                for i in 0..BATCH as u32 {
                    let eye = sphere.orbit(b * BATCH as u32 + i);
                    self.sink = self.sink.wrapping_add(expanded.query(eye).bits()[0]);
                }
                t.elapsed().as_nanos() as f64 / BATCH as f64
            })
            .collect()
    }

    /// Streaming, the camera staying in its leaf: a batch of tiny jitters around each of the
    /// first eyes (one per batch); ns per query.
    fn streaming_stay(&mut self) -> Vec<f64> {
        let sphere = self.sphere;
        let mut scratch = vec![0u64; self.pvis.scratch_bound()];
        let mut streaming = self.pvis.streaming(&mut scratch);
        let mut stay = Vec::new();
        for b in 0..self.batches {
            let base = self.eyes[b];
            streaming.query(base);
            let mut jitter = Vec::with_capacity(BATCH);
            for _ in 0..BATCH {
                let d = [0, 1, 2].map(|i| {
                    (base[i] - sphere.center[i]) / sphere.radius + 1e-5 * self.next.next()
                });
                jitter.push(sphere.eye(d));
            }
            // Each path the jittered eyes use is walked once before the clock starts: a camera
            // moving about in its leaf decodes nothing (an eye on a sphere of views may be
            // answered by either band around it).
            for &eye in &jitter {
                streaming.query(eye);
            }
            let t = Instant::now();
            for &eye in &jitter {
                self.sink = self.sink.wrapping_add(streaming.query(eye).bits()[0]);
            }
            stay.push(t.elapsed().as_nanos() as f64 / BATCH as f64);
        }
        stay
    }

    /// Streaming along the smooth orbit's first `n` steps: every query timed, those that
    /// change leaf apart.
    fn streaming_orbit(&mut self, n: u32) -> OrbitTimes {
        let mut scratch = vec![0u64; self.pvis.scratch_bound()];
        let mut streaming = self.pvis.streaming(&mut scratch);
        let mut last_leaf = streaming.query(self.sphere.orbit(0)).leaf;
        let mut times = OrbitTimes {
            changes: Vec::new(),
            all: Vec::new(),
            rows_per_change: 0.0,
        };
        let decoded_before = streaming.decoded_rows();
        for i in 1..n {
            let eye = self.sphere.orbit(i);
            let t = Instant::now();
            let visible = streaming.query(eye);
            let ns = t.elapsed().as_nanos() as f64;
            self.sink = self.sink.wrapping_add(visible.bits()[0]);
            times.all.push(ns);
            if visible.leaf != last_leaf {
                last_leaf = visible.leaf;
                times.changes.push(ns);
            }
        }
        times.rows_per_change =
            (streaming.decoded_rows() - decoded_before) as f64 / times.changes.len().max(1) as f64;
        times
    }
}

/// Where a bench's eyes lie: on the sphere of 1.5 times the sampling distance.
#[derive(Clone, Copy)]
struct EyeSphere {
    center: [f32; 3],
    radius: f32,
}

impl EyeSphere {
    /// The eye in direction `d` (not unit).
    fn eye(&self, d: [f32; 3]) -> [f32; 3] {
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-6);
        [0, 1, 2].map(|i| self.center[i] + d[i] / len * self.radius)
    }

    /// Step `i` of a smooth orbit: 0.05° a step on a tilted great circle.
    fn orbit(&self, i: u32) -> [f32; 3] {
        let a = i as f32 * 0.05f32.to_radians();
        self.eye([a.cos(), 0.35 * a.sin(), a.sin()])
    }
}

/// The expanded query with and without a frustum ([`Bench::expanded_frustum`]).
struct FrustumTimes {
    /// ns to build one frustum from its matrix.
    build_ns: f64,
    /// ns per plain query, per batch.
    plain: Vec<f64>,
    /// ns per query in the frustum that holds the model, per batch.
    centred: Vec<f64>,
    /// ns per query in the frustum that cuts the model, per batch.
    cut: Vec<f64>,
    /// Visible patches the cutting frustum kept, of `total`.
    kept: u64,
    total: u64,
}

impl FrustumTimes {
    /// The report's lines, for cameras of `fov_deg`.
    fn print(&mut self, fov_deg: f32) -> Result<()> {
        outln!(
            "  expanded, same eyes (alternated below)   {:>10.0} ns",
            median(&mut self.plain)
        )?;
        outln!(
            "  expanded + frustum, model inside it      {:>10.0} ns   (looking at the centre, fov {})",
            median(&mut self.centred),
            fov_deg
        )?;
        outln!(
            "  expanded + frustum, side cutting model   {:>10.0} ns   (aimed 1.5 radii off: {:.1}% of visible patches kept)",
            median(&mut self.cut),
            100.0 * self.kept as f64 / self.total.max(1) as f64
        )?;
        outln!(
            "  Frustum::from_view_projection            {:>10.0} ns",
            self.build_ns
        )?;
        Ok(())
    }
}

/// Streaming along the smooth orbit ([`Bench::streaming_orbit`]).
struct OrbitTimes {
    /// ns of each query that changed leaf.
    changes: Vec<f64>,
    /// ns of every query.
    all: Vec<f64>,
    /// Rows decoded per leaf change.
    rows_per_change: f64,
}

impl OrbitTimes {
    /// The report's lines, for an orbit of `n` eyes.
    fn print(&mut self, n: u32) -> Result<()> {
        outln!(
            "  streaming, leaf change on smooth orbit   {:>10.0} ns   ({} changes in {} steps, {:.1} rows decoded per change)",
            median(&mut self.changes),
            self.changes.len(),
            n - 1,
            self.rows_per_change
        )?;
        outln!(
            "  streaming, every orbit step              {:>10.0} ns",
            median(&mut self.all)
        )?;
        Ok(())
    }
}

/// A seeded xorshift stream of floats in `[-1, 1)`, so benches query the same eyes every run.
struct Seeded {
    state: u64,
}

impl Seeded {
    fn new(seed: u64) -> Seeded {
        Seeded { state: seed | 1 }
    }

    /// The next float.
    fn next(&mut self) -> f32 {
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        (self.state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }
}

/// Median of `samples` (sorted in place).
fn median(samples: &mut [f64]) -> f64 {
    samples.sort_by(f64::total_cmp);
    samples.get(samples.len() / 2).copied().unwrap_or(f64::NAN)
}
