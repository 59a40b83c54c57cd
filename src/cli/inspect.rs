//! `patchvis info` and `patchvis query`: read a `.pvis` through the runtime reader, and
//! (`info --compare`, `query --bench`) measure its payload and its three query modes.

use super::UsageError;
use super::args::{DepthArg, InfoArgs, QueryArgs, memory_budget};
use super::out::outln;
use super::view::LookAt;
use anyhow::{Context, Result, anyhow};
use patchvis::format::PvisFile;
use patchvis::runtime::{DepthRange, Frustum, Pvis};
use serde_json::json;
use std::path::Path;

/// The file, mapped once its signature is checked (a FIFO or device is refused unopened).
fn read(path: &Path) -> Result<PvisFile> {
    PvisFile::open(path).map_err(|e| anyhow!("{}: {e}", path.display()))
}

fn parse<'a>(path: &Path, bytes: &'a [u8]) -> Result<Pvis<'a>> {
    Pvis::parse(bytes).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// The shells of a file's SHEL records (`0..=K` less the sampling sphere's `J`), outermost
/// first.
fn records(pvis: &Pvis<'_>) -> impl Iterator<Item = u32> {
    let sampling = pvis.sampling_shell();
    (0..=pvis.shell_count()).filter(move |&s| s != sampling)
}

/// Runs `patchvis info`.
pub fn info(args: &InfoArgs) -> Result<()> {
    let bytes = read(&args.file)?;
    let pvis = parse(&args.file, &bytes)?;
    if args.compare {
        // A small file can hold a large matrix: refused before anything is printed.
        let (need, budget) = (compare_bytes(&pvis), memory_budget(args.memory).total());
        if need > budget {
            return Err(anyhow!(
                "{}: info --compare holds {need} bytes for this file ({} views x {} patches, \
                 the matrix three times), more than --memory {budget} bytes; give a larger \
                 --memory",
                args.file.display(),
                pvis.sampling().views,
                pvis.patch_count()
            ));
        }
    }
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
            "sampling_shell": pvis.sampling_shell(),
            "sampling_reach": pvis.sampling_reach(),
            "shells": records(&pvis).map(|k| {
                let shell = pvis.shell(k);
                json!({
                    "shell": k,
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
            if pvis.sampling_shell() > 0 {
                outln!(
                    "    the sampling sphere is shell {}, the shells before it lie beyond it",
                    pvis.sampling_shell()
                )?;
            }
            if pvis.sampling_reach() > 0.0 {
                outln!(
                    "    the sampling sphere alone answers out to {} ({:.4} sampling distances)",
                    pvis.sampling_reach(),
                    pvis.sampling_reach() / s.distance
                )?;
            }
            for k in records(&pvis) {
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

/// Heap bytes `info --compare` holds for `pvis`: every row decoded (the expanded table), then
/// the raw rows twice ([`raw_matrices`]).
fn compare_bytes(pvis: &Pvis<'_>) -> u64 {
    let raw = u64::from(pvis.sampling().views) * u64::from(pvis.patch_count()).div_ceil(8);
    8 * pvis.expanded_bound() as u64 + 2 * raw
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
        return super::query_bench::bench(&pvis, n.max(1));
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
