//! `patchvis info` and `patchvis query`: read a `.pvis` through the runtime reader, and
//! (`info --compare`, `query --bench`) measure its payload and its three query modes.

use super::UsageError;
use super::args::{DepthArg, InfoArgs, QueryArgs};
use super::out::outln;
use super::view::LookAt;
use anyhow::{Context, Result, anyhow};
use patchvis::format::PvisFile;
use patchvis::runtime::{DepthRange, Frustum, Pvis};
use serde_json::json;
use std::path::Path;
use std::time::Instant;

/// The file, mapped once its signature is checked (a FIFO or device is refused unopened).
fn read(path: &Path) -> Result<PvisFile> {
    PvisFile::open(path).map_err(|e| anyhow!("{}: {e}", path.display()))
}

fn parse<'a>(path: &Path, bytes: &'a [u8]) -> Result<Pvis<'a>> {
    Pvis::parse(bytes).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Runs `patchvis info`.
pub fn info(args: &InfoArgs) -> Result<()> {
    let bytes = read(&args.file)?;
    let pvis = parse(&args.file, &bytes)?;
    let s = pvis.sampling();
    if args.json {
        let report = json!({
            "version": pvis.version(),
            "patches": pvis.patch_count(),
            "triangles": pvis.triangle_count(),
            "level": s.level,
            "views": s.views,
            "camera": {
                "center": s.center,
                "radius": s.radius,
                "distance": s.distance,
                "fov_deg": s.fov_deg,
                "resolution": s.resolution,
            },
            "bytes": {
                "total": pvis.total_bytes(),
                "visibility": pvis.visibility_bytes(),
                "patch_table": pvis.patch_table_bytes(),
                "shells": pvis.shells_bytes(),
            },
            "shells": (1..=pvis.shell_count()).map(|k| {
                let shell = pvis.shell(k);
                json!({
                    "distance": shell.distance,
                    "level": shell.level,
                    "views": shell.views,
                    "encoding": shell.encoding,
                    "bytes": shell.bytes,
                })
            }).collect::<Vec<_>>(),
        });
        outln!("{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        outln!(
            "{}: patchvis file version {}",
            args.file.display(),
            pvis.version()
        )?;
        outln!(
            "  {} patches over {} triangles",
            pvis.patch_count(),
            pvis.triangle_count()
        )?;
        outln!(
            "  {} views (sphere level {}), {}x{} px, fov {}°",
            s.views,
            s.level,
            s.resolution,
            s.resolution,
            s.fov_deg
        )?;
        outln!(
            "  centre [{}, {}, {}], radius {}, camera distance {}",
            s.center[0],
            s.center[1],
            s.center[2],
            s.radius,
            s.distance
        )?;
        outln!(
            "  {} bytes, of which visibility {} (encoding {}) and patch table {} ({})",
            pvis.total_bytes(),
            pvis.visibility_bytes(),
            pvis.encoding(),
            pvis.patch_table_bytes(),
            if pvis.quantisation().is_some() {
                "compact"
            } else {
                "full"
            }
        )?;
        if pvis.shell_count() > 0 {
            outln!(
                "  {} sampling shells, {} bytes (SHEL section):",
                pvis.shell_count(),
                pvis.shells_bytes()
            )?;
            for k in 1..=pvis.shell_count() {
                let shell = pvis.shell(k);
                outln!(
                    "    shell {k}: distance {} ({:.3} radii), {} views (level {}), {} bytes (encoding {})",
                    shell.distance,
                    shell.distance / s.radius,
                    shell.views,
                    shell.level,
                    shell.bytes,
                    shell.encoding
                )?;
            }
        }
    }
    if args.compare {
        compare(&pvis)?;
    }
    Ok(())
}

/// The raw row-major matrix of a file, `ceil(P / 8)` bytes per view as VISB encoding 0: in
/// the file's patch order, and with the patches in `order` (`order[i]` becomes bit `i`).
fn raw_matrices(pvis: &Pvis<'_>, order: &[u32]) -> (Vec<u8>, Vec<u8>) {
    let mut table = vec![0u64; pvis.expanded_bound()];
    let expanded = pvis.expand(&mut table);
    let row_bytes = (pvis.patch_count() as usize).div_ceil(8);
    let views = pvis.sampling().views as usize;
    let (mut raw, mut reordered) = (
        Vec::with_capacity(row_bytes * views),
        vec![0u8; row_bytes * views],
    );
    for v in 0..pvis.sampling().views {
        let start = raw.len();
        let row = expanded.row(v);
        raw.extend(row.iter().flat_map(|w| w.to_le_bytes()));
        raw.truncate(start + row_bytes);
        for (i, &p) in order.iter().enumerate() {
            let bit = (row[p as usize / 64] >> (p % 64) & 1) as u8;
            reordered[start + i / 8] |= bit << (i % 8);
        }
    }
    (raw, reordered)
}

/// Size of `data` compressed by the zstd library at `level`, as `zstd -<level>` would.
fn zstd_size(data: &[u8], level: i32) -> Result<usize> {
    Ok(zstd::bulk::compress(data, level)
        .context("zstd compression failed")?
        .len())
}

/// Size of `data` as an `.xz` stream (CRC64 check) from liblzma at `preset`, as `xz -<preset>`.
fn xz_size(data: &[u8], preset: u32) -> Result<usize> {
    Ok(liblzma::encode_all(data, preset)
        .context("xz compression failed")?
        .len())
}

/// `info --compare`: the payload next to generic compressors on the raw matrix.
fn compare(pvis: &Pvis<'_>) -> Result<()> {
    let centres: Vec<[f32; 3]> = (0..pvis.patch_count())
        .map(|p| pvis.patch(p).center)
        .collect();
    let (raw, spatial) = raw_matrices(pvis, &patchvis::format::centre_order(&centres));
    let zstd = zstd_size(&raw, 19)?;
    let xz = xz_size(&raw, 9)?;
    let zstd_spatial = zstd_size(&spatial, 19)?;
    let ours = pvis.visibility_bytes() as usize;
    let show = |name: &str, s: usize| {
        outln!(
            "  {name:<28}{s:>10} B  {:>6.3} x raw  {:>6.3} x zstd",
            s as f64 / raw.len() as f64,
            s as f64 / zstd as f64
        )
    };
    outln!(
        "visibility payload, {} views x {} patches:",
        pvis.sampling().views,
        pvis.patch_count()
    )?;
    show("raw rows", raw.len())?;
    show("zstd -19 (raw rows)", zstd)?;
    show("xz -9 (raw rows)", xz)?;
    show("VISB in this file", ours)?;
    // A file numbered by co-visibility has rows that zstd also compresses better; the same
    // matrix with the patches in spatial (Z-order) numbering is the baseline before that.
    outln!("  same matrix, patches in Z-order of their centres (spatial numbering):")?;
    outln!(
        "  {:<28}{zstd_spatial:>10} B  VISB in this file: {:.3} x this",
        "zstd -19 (rows)",
        ours as f64 / zstd_spatial as f64
    )?;
    Ok(())
}

/// Runs `patchvis query`.
pub fn query(args: &QueryArgs) -> Result<()> {
    let bytes = read(&args.file)?;
    let pvis = parse(&args.file, &bytes)?;
    if let Some(n) = args.bench {
        return bench(&pvis, n.max(1));
    }
    let Some(from) = args.from else {
        return Err(anyhow!("query: --from X,Y,Z is required without --bench"));
    };
    let frustum = query_frustum(args, from)?;
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let unculled = pvis.query(from, &mut scratch).count();
    let visible = match &frustum {
        Some(frustum) => pvis.query_in_frustum(from, frustum, &mut scratch),
        None => pvis.query(from, &mut scratch),
    };
    let patches: Vec<u32> = visible.patches().collect();
    let outside = unculled - visible.count();
    // The reader merges neighbouring patches' ranges into one draw each.
    let ranges: Vec<[u32; 2]> = pvis
        .ranges(&visible)
        .map(|(first, count)| [first, count])
        .collect();
    let triangles: u64 = ranges.iter().map(|r| u64::from(r[1])).sum();
    if args.json {
        let mut report = json!({
            "patches": patches,
            "ranges": ranges,
            "inside_sphere": visible.inside_sphere,
            "band": visible.band,
            "shells": visible.shells,
            "triangles": triangles,
            "views": visible.leaf,
            "inner_views": visible.inner_leaf,
        });
        if frustum.is_some() {
            report["outside_frustum"] = json!(outside);
        }
        outln!("{}", serde_json::to_string(&report)?)?;
    } else {
        let what = if frustum.is_some() {
            format!(
                "visible and in the frustum ({unculled} visible, {outside} outside the frustum)"
            )
        } else {
            "visible".into()
        };
        let views = match visible.shells {
            [0, 0] => format!("views {:?}", visible.leaf),
            [a, b] if a == b => format!("views {:?} of shell {a}", visible.leaf),
            [a, b] => format!(
                "views {:?} of shell {a} and {:?} of shell {b}",
                visible.leaf, visible.inner_leaf
            ),
        };
        outln!(
            "{} of {} patches {what}, {} of {} triangles in {} ranges ({views}; band {})",
            patches.len(),
            pvis.patch_count(),
            triangles,
            pvis.triangle_count(),
            ranges.len(),
            visible.band
        )?;
        if visible.inside_sphere {
            let sphere = match pvis.shell_count() {
                0 => "the sampling sphere",
                _ => "the innermost sampling shell",
            };
            outln!("the camera is inside {sphere}: draw everything")?;
        }
    }
    Ok(())
}

/// The frustum of `query`'s camera flags (`--look-at` and its lens, or `--view-proj`), if any.
fn query_frustum(args: &QueryArgs, eye: [f32; 3]) -> Result<Option<Frustum>, UsageError> {
    if let Some(m) = args.view_proj {
        let depth = match args.depth {
            DepthArg::Gl => DepthRange::NegativeOneToOne,
            DepthArg::ZeroToOne => DepthRange::ZeroToOne,
        };
        return Ok(Some(Frustum::from_view_projection(&m, depth)));
    }
    args.look_at
        .map(|target| {
            LookAt {
                eye,
                target,
                fov_deg: args.fov,
                aspect: args.aspect,
                near: args.near,
                far: args.far,
            }
            .frustum()
        })
        .transpose()
}

/// A seeded xorshift stream of floats in `[-1, 1)`, so benches query the same eyes every run.
fn seeded(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed | 1;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }
}

/// Median of `samples` (sorted in place).
fn median(samples: &mut [f64]) -> f64 {
    samples.sort_by(f64::total_cmp);
    samples.get(samples.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Queries per timed batch for the sub-microsecond modes: long enough to dwarf the clock's
/// own cost (~25 ns per `Instant::now`), short enough to give many samples.
const BATCH: usize = 64;

/// `query --bench N`: median time per query of each mode, on seeded eyes at twice the
/// sampling distance.
fn bench(pvis: &Pvis<'_>, n: u32) -> Result<()> {
    let s = pvis.sampling();
    let radius = 2.0 * s.distance;
    let eye_at = |d: [f32; 3]| {
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-6);
        [0, 1, 2].map(|i| s.center[i] + d[i] / len * radius)
    };
    let mut next = seeded(0x5EED);
    let eyes: Vec<[f32; 3]> = (0..n.max(BATCH as u32))
        .map(|_| eye_at([next(), next(), next()]))
        .collect();
    let batches = eyes.len() / BATCH;
    let mut sink = 0u64;

    // Stateless `Pvis::query`: lock-step decode of the leaf's corners (the baseline).
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let stateless_n = eyes.len().min(200);
    let mut stateless: Vec<f64> = eyes[..stateless_n]
        .iter()
        .map(|&eye| {
            let t = Instant::now();
            sink = sink.wrapping_add(u64::from(pvis.query(eye, &mut scratch).count()));
            t.elapsed().as_nanos() as f64
        })
        .collect();

    // Expanded: random eyes, each usually in a new leaf.
    let t = Instant::now();
    let mut table = vec![0u64; pvis.expanded_bound()];
    let mut expanded = pvis.expand(&mut table);
    let expand_ms = t.elapsed().as_secs_f64() * 1e3;
    let mut exp: Vec<f64> = (0..batches)
        .map(|b| {
            let t = Instant::now();
            for &eye in &eyes[b * BATCH..(b + 1) * BATCH] {
                sink = sink.wrapping_add(expanded.query(eye).bits()[0]);
            }
            t.elapsed().as_nanos() as f64 / BATCH as f64
        })
        .collect();

    // Expanded with a frustum, alternated batch by batch with the plain query above so that
    // both see the same machine: a camera looking at the model's centre (the frustum holds
    // the whole model) and one aimed 1.5 radii off it, so the frustum's side cuts the model.
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
    let mut matrices = Vec::with_capacity(2 * eyes.len());
    for &eye in &eyes {
        matrices.push(aimed(eye, 0.0)?);
        matrices.push(aimed(eye, 1.5)?);
    }
    let t = Instant::now();
    let frusta: Vec<Frustum> = matrices
        .iter()
        .map(|m| Frustum::from_view_projection(m, DepthRange::NegativeOneToOne))
        .collect();
    let frustum_build_ns = t.elapsed().as_nanos() as f64 / frusta.len() as f64;
    let (mut plain, mut centred, mut cut) = (Vec::new(), Vec::new(), Vec::new());
    let (mut kept, mut total) = (0u64, 0u64);
    for b in 0..batches {
        let range = b * BATCH..(b + 1) * BATCH;
        let t = Instant::now();
        for &eye in &eyes[range.clone()] {
            sink = sink.wrapping_add(expanded.query(eye).bits()[0]);
        }
        plain.push(t.elapsed().as_nanos() as f64 / BATCH as f64);
        for (k, times) in [(0, &mut centred), (1, &mut cut)] {
            let t = Instant::now();
            for i in range.clone() {
                let v = expanded.query_in_frustum(eyes[i], &frusta[2 * i + k]);
                sink = sink.wrapping_add(v.bits()[0]);
            }
            times.push(t.elapsed().as_nanos() as f64 / BATCH as f64);
        }
        for i in range {
            total += u64::from(expanded.query(eyes[i]).count());
            kept += u64::from(
                expanded
                    .query_in_frustum(eyes[i], &frusta[2 * i + 1])
                    .count(),
            );
        }
    }

    // Expanded along the smooth orbit below: mostly the same leaf, sometimes a neighbour.
    let orbit_eye = |i: u32| {
        let a = i as f32 * 0.05f32.to_radians();
        eye_at([a.cos(), 0.35 * a.sin(), a.sin()])
    };
    let mut exp_orbit: Vec<f64> = (0..batches as u32)
        .map(|b| {
            let t = Instant::now();
            for i in 0..BATCH as u32 {
                sink = sink.wrapping_add(expanded.query(orbit_eye(b * BATCH as u32 + i)).bits()[0]);
            }
            t.elapsed().as_nanos() as f64 / BATCH as f64
        })
        .collect();

    // Streaming, staying in a leaf: tiny jitter around each of a few seeded eyes.
    let mut stream_scratch = vec![0u64; pvis.scratch_bound()];
    let mut streaming = pvis.streaming(&mut stream_scratch);
    let mut stay: Vec<f64> = Vec::new();
    for &base in &eyes[..batches] {
        streaming.query(base);
        let jitter: Vec<[f32; 3]> = (0..BATCH)
            .map(|_| eye_at([0, 1, 2].map(|i| (base[i] - s.center[i]) / radius + 1e-5 * next())))
            .collect();
        let t = Instant::now();
        for &eye in &jitter {
            sink = sink.wrapping_add(streaming.query(eye).bits()[0]);
        }
        stay.push(t.elapsed().as_nanos() as f64 / BATCH as f64);
    }

    // Streaming along a smooth orbit: N steps of 0.05° on a tilted great circle; time the
    // queries that change leaf.
    let mut stream_scratch = vec![0u64; pvis.scratch_bound()];
    let mut streaming = pvis.streaming(&mut stream_scratch);
    let orbit = orbit_eye;
    let mut last_leaf = streaming.query(orbit(0)).leaf;
    let mut changes: Vec<f64> = Vec::new();
    let mut orbit_all: Vec<f64> = Vec::new();
    let decoded_before = streaming.decoded_rows();
    for i in 1..n {
        let eye = orbit(i);
        let t = Instant::now();
        let visible = streaming.query(eye);
        let ns = t.elapsed().as_nanos() as f64;
        sink = sink.wrapping_add(visible.bits()[0]);
        orbit_all.push(ns);
        if visible.leaf != last_leaf {
            last_leaf = visible.leaf;
            changes.push(ns);
        }
    }
    let rows_per_change =
        (streaming.decoded_rows() - decoded_before) as f64 / changes.len().max(1) as f64;
    std::hint::black_box(sink);

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
        stateless_n
    )?;
    outln!(
        "  expanded query, random eyes              {:>10.0} ns   (expand once: {:.1} ms, {} KiB table)",
        median(&mut exp),
        expand_ms,
        pvis.expanded_bound() * 8 / 1024
    )?;
    outln!(
        "  expanded, same eyes (alternated below)   {:>10.0} ns",
        median(&mut plain)
    )?;
    outln!(
        "  expanded + frustum, model inside it      {:>10.0} ns   (looking at the centre, fov {})",
        median(&mut centred),
        s.fov_deg
    )?;
    outln!(
        "  expanded + frustum, side cutting model   {:>10.0} ns   (aimed 1.5 radii off: {:.1}% of visible patches kept)",
        median(&mut cut),
        100.0 * kept as f64 / total.max(1) as f64
    )?;
    outln!(
        "  Frustum::from_view_projection            {:>10.0} ns",
        frustum_build_ns
    )?;
    outln!(
        "  expanded query, smooth orbit             {:>10.0} ns",
        median(&mut exp_orbit)
    )?;
    outln!(
        "  streaming, camera staying in its leaf    {:>10.0} ns   ({} KiB scratch)",
        median(&mut stay),
        pvis.scratch_bound() * 8 / 1024
    )?;
    outln!(
        "  streaming, leaf change on smooth orbit   {:>10.0} ns   ({} changes in {} steps, {:.1} rows decoded per change)",
        median(&mut changes),
        changes.len(),
        n - 1,
        rows_per_change
    )?;
    outln!(
        "  streaming, every orbit step              {:>10.0} ns",
        median(&mut orbit_all)
    )?;
    Ok(())
}
