//! `patchvis eval`: checked settings, then the library's evaluation (`patchvis::eval`) over
//! random views, sampling views or a path, at one distance or a band per distance
//! (`eval_bands.rs`), or a sweep of bakes; a text or JSON report, PNGs of the worst views and
//! SVG plots.

use super::UsageError;
use super::args::{EvalArgs, SweepModeArg, memory_budget};
use super::eval_bands::{Band, parse_distance_scales, print_bands};
use super::eval_frame::{FrameBackend, frame_json, gpu_json, print_frame};
use super::out::{StdoutError, outln};
use super::progress::Bars;
use anyhow::{Context, Result, anyhow};
use patchvis::bake::{
    BakeSettings, DEFAULT_FOLD_MIN_PIXELS, DEFAULT_PROBE_PIXELS, DEFAULT_VIEW_SUPERSAMPLE,
    MemoryBudget, PROBE_FOLD_CORNERS, Probe, Research, RowSettings, Stages,
};
use patchvis::eval::plot::{self, Axis, Chart, Series};
use patchvis::eval::shade::RgbImage;
use patchvis::eval::views::{self, PathCamera};
use patchvis::eval::{
    EvalOptions, EvalSummary, Evaluator, SweepPoint, SweepSettings, ViewMetrics, metrics::Summary,
    sampling_params,
};
use patchvis::format::{PvisFile, write_atomic};
use patchvis::memory::DEFAULT_PROBE_MAX_TRIANGLES;
use patchvis::ooc::Mesh;
use patchvis::output::{NamedPath, check_outputs};
use patchvis::runtime::Pvis;
use patchvis::sampler::FoldCorners;
use patchvis::sampler::{Camera, MAX_RESOLUTION};
use patchvis::sphere::{MAX_LEVEL, view_count};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Frames of `--path orbit` without a count.
const DEFAULT_ORBIT_FRAMES: u32 = 120;
/// Resolution of `--sweep`'s bakes unless `--resolution` says otherwise (the bake default).
const DEFAULT_SWEEP_RESOLUTION: u32 = 512;
/// Identical frames have infinite PSNR; the path plot draws them at this height.
const PSNR_PLOT_CAP_DB: f64 = 60.0;

/// Which cameras to evaluate.
#[derive(Debug)]
enum Views {
    /// Seeded random positions on the (scaled) sampling sphere.
    Random { count: u32, seed: u64 },
    /// The sampling positions of a sphere level.
    Sampling { level: u32 },
    /// An orbit of `frames` frames.
    Orbit { frames: u32 },
    /// Cameras from a file.
    PathFile(PathBuf),
}

fn parse_path(spec: &str) -> Result<Views, UsageError> {
    let Some(rest) = spec.strip_prefix("orbit") else {
        return Ok(Views::PathFile(PathBuf::from(spec)));
    };
    let frames = match rest.strip_prefix(':') {
        None if rest.is_empty() => DEFAULT_ORBIT_FRAMES,
        Some(n) => match n.parse::<u32>() {
            Ok(n) if n > 0 => n,
            _ => {
                return Err(UsageError(format!(
                    "--path {spec}: expected orbit:N with N a positive frame count"
                )));
            }
        },
        // "orbitfoo" is a file name.
        None => return Ok(Views::PathFile(PathBuf::from(spec))),
    };
    Ok(Views::Orbit { frames })
}

fn usage(condition: bool, message: impl FnOnce() -> String) -> Result<(), UsageError> {
    if condition {
        Err(UsageError(message()))
    } else {
        Ok(())
    }
}

/// Runs `patchvis eval`.
pub fn run(args: EvalArgs) -> Result<()> {
    let scales = parse_distance_scales(&args.distance_scale)?;
    if let Some(r) = args.resolution {
        usage(r == 0 || r > MAX_RESOLUTION, || {
            format!("--resolution {r}: expected 1 to {MAX_RESOLUTION} pixels")
        })?;
    }
    usage(
        !(args.look_jitter >= 0.0 && args.look_jitter <= 180.0),
        || {
            format!(
                "--look-jitter {}: expected degrees from 0 to 180",
                args.look_jitter
            )
        },
    )?;
    let listed = |mode: &str| {
        usage(scales.len() > 1, || {
            format!(
                "--distance-scale {}: a list of distances is not supported with {mode}; give one distance",
                args.distance_scale
            )
        })
    };
    if args.sweep {
        listed("--sweep")?;
    }
    if args.path.is_some() {
        listed("--path")?;
    }
    if let Some(dir) = &args.png {
        check_output_dir(dir)?;
    }
    if args.sweep {
        return run_sweep(&args, scales[0]);
    }
    let views = match (&args.path, args.sampling_level) {
        (Some(spec), _) => parse_path(spec)?,
        (None, Some(level)) => Views::Sampling { level },
        (None, None) => {
            usage(args.views == 0, || "--views 0: expected at least 1".into())?;
            Views::Random {
                count: args.views,
                seed: args.seed,
            }
        }
    };
    let file = args
        .file
        .clone()
        .ok_or_else(|| UsageError("expected FILE.pvis (or --sweep)".into()))?;

    if let Some(stats) = &args.stats {
        let inputs = [
            NamedPath::new("the mesh", "MESH", &args.mesh),
            NamedPath::new("the .pvis file", "FILE", &file),
        ];
        check_outputs(&inputs, &[NamedPath::flag("--stats", stats)])
            .map_err(|e| UsageError(e.to_string()))?;
    }
    let bars = Bars::new(!args.quiet && !args.json);
    let start = Instant::now();
    let options = EvalOptions {
        memory: memory_budget(args.memory),
        tiling: args.tiling.into(),
    };
    let mut stages = Stages::new();
    // The file first: refusing it costs nothing, converting the mesh may cost minutes.
    let bytes = PvisFile::open(&file).map_err(|e| anyhow!("{}: {e}", file.display()))?;
    let pvis = Pvis::parse(&bytes).map_err(|e| anyhow!("{}: {e}", file.display()))?;
    let mesh = stages.run("input", || open_mesh(&args, options.memory))?;
    let evaluator = stages
        .run("patches", || Evaluator::new(&mesh, &pvis, &options))
        .map_err(|e| {
            anyhow!(
                "{} was not baked from {} with these settings: {e}",
                file.display(),
                args.mesh.display()
            )
        })?;
    // After the inputs are checked, so that their errors come first and alone (probing for
    // an adapter can make the driver write to stderr), before the long evaluation, so that a
    // missing GPU fails soon.
    let frame_backend = FrameBackend::open(args.frame_backend)?;
    let sampling = pvis.sampling();
    let resolution = args.resolution.unwrap_or(sampling.resolution);
    if let Views::Sampling { level } = views {
        usage(level > sampling.level, || {
            format!(
                "--sampling-level {level}: expected at most the file's level {}",
                sampling.level
            )
        })?;
    }
    let is_path = matches!(views, Views::Orbit { .. } | Views::PathFile(_));
    let banded = scales.len() > 1;
    let mut bands = Vec::with_capacity(scales.len());
    for &scale in &scales {
        let params = sampling_params(&pvis, resolution, scale);
        let cameras: Vec<Camera> = match &views {
            Views::Random { count, seed } => views::random_directions(*count, *seed)
                .into_iter()
                .map(|d| Camera::sampling(&params, d))
                .collect(),
            Views::Sampling { level } => (0..view_count(*level))
                .map(|v| Camera::sampling_view(&params, v))
                .collect(),
            Views::Orbit { frames } => views::orbit_directions(*frames)
                .into_iter()
                .map(|d| Camera::sampling(&params, d))
                .collect(),
            Views::PathFile(path) => {
                path_cameras(path, &sampling.center, sampling.fov_deg, resolution)?
            }
        };
        // The same seed in every band: the same turn for the same camera.
        let cameras = views::jitter_looks(&cameras, f64::from(args.look_jitter), args.seed);
        let metrics = stages.run("eval", || evaluator.evaluate(&pvis, &cameras, &bars));
        let summary = EvalSummary::of(&metrics);
        // After the CPU evaluation, never beside it: a software GPU shares its cores.
        let gpu = frame_backend.measure(&evaluator, &pvis, &cameras, &bars)?;
        bands.push(Band {
            scale,
            distance: params.distance(),
            cameras,
            metrics,
            summary,
            gpu,
            pictures: Vec::new(),
        });
    }
    let seconds = start.elapsed().as_secs_f64();
    if let Some(path) = &args.stats {
        let mut report = json!({
            "mesh": args.mesh.display().to_string(),
            "file": file.display().to_string(),
            "triangles": mesh.triangle_count(),
            "patches_from": if evaluator.order().is_some() { "tiling" } else { "mesh order" },
            "memory_budget_bytes": options.memory.total(),
            "workers": evaluator.workers(&bands[0].cameras[0]),
            "seconds": seconds,
            "peak_heap_bytes": stages.peak_heap_bytes(),
            "look_jitter_deg": args.look_jitter,
        });
        if banded {
            let rows = bands
                .iter()
                .map(|b| {
                    let mut row = json!({"distance_scale": b.scale});
                    merge(&mut row, stats_culling_json(&b.summary));
                    row
                })
                .collect::<Vec<_>>();
            merge(&mut report, json!({ "bands": rows }));
        } else {
            merge(&mut report, stats_culling_json(&bands[0].summary));
        }
        merge(
            &mut report,
            json!({
                "stages": stages.records().iter().map(|r| json!({
                    "name": r.name, "seconds": r.seconds, "peak_heap_bytes": r.peak_heap_bytes,
                })).collect::<Vec<_>>(),
            }),
        );
        let text = serde_json::to_string_pretty(&report)? + "\n";
        write_atomic(path, text.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }

    let mut written = Vec::new();
    if let Some(dir) = &args.png {
        let prefix = if is_path { "frame" } else { "view" };
        for band in &mut bands {
            for index in worst(&band.metrics, args.worst) {
                let pictures = evaluator.pictures(&pvis, &band.cameras[index]);
                let image = RgbImage::side_by_side(&[
                    &pictures.full,
                    &pictures.reconstruction,
                    &pictures.difference,
                ]);
                let name = if banded {
                    format!("{prefix}-x{}-{index:04}.png", band.scale)
                } else {
                    format!("{prefix}-{index:04}.png")
                };
                let path = dir.join(name);
                write_png(&path, &image)?;
                band.pictures.push(path.clone());
                written.push(path);
            }
        }
        if is_path {
            let path = dir.join("path.svg");
            write_atomic(&path, path_plot(&bands[0].metrics).as_bytes())
                .with_context(|| format!("{}: cannot write", path.display()))?;
            written.push(path);
        }
    }

    let mode = match &views {
        Views::Random { .. } => "random".to_string(),
        Views::Sampling { level } => format!("sampling level {level}"),
        Views::Orbit { frames } => format!("orbit of {frames} frames"),
        Views::PathFile(p) => format!("path {}", p.display()),
    };
    if args.json {
        let mut report = if banded {
            json!({})
        } else {
            summary_json(&bands[0].summary)
        };
        let extra = json!({
            "mesh": args.mesh.display().to_string(),
            "file": file.display().to_string(),
            "mode": mode,
            "seed": args.seed,
        });
        merge(&mut report, extra);
        if banded {
            merge(
                &mut report,
                json!({"distance_scales": scales, "views_per_band": bands[0].summary.views}),
            );
        } else {
            merge(
                &mut report,
                json!({
                    "distance_scale": bands[0].scale,
                    "distance": bands[0].distance,
                    "distance_radii": bands[0].radii(&pvis),
                }),
            );
        }
        let extra = json!({
            "look_jitter_deg": args.look_jitter,
            "resolution": resolution,
            "patches": pvis.patch_count(),
            "triangles": mesh.triangle_count(),
            "level": sampling.level,
            "sampling_views": sampling.views,
            "file_bytes": pvis.total_bytes(),
            "seconds": seconds,
            "pictures": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        });
        merge(&mut report, extra);
        if banded {
            merge(&mut report, frame_json(&frame_backend, None));
            let rows = bands
                .iter()
                .map(|b| {
                    let mut row = json!({
                        "distance_scale": b.scale,
                        "distance": b.distance,
                        "distance_radii": b.radii(&pvis),
                    });
                    merge(&mut row, summary_json(&b.summary));
                    merge(
                        &mut row,
                        json!({
                            "pictures": b.pictures.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
                            "per_view": per_view_json(b),
                        }),
                    );
                    merge(&mut row, gpu_json(b.gpu.as_ref()));
                    row
                })
                .collect::<Vec<_>>();
            merge(&mut report, json!({ "bands": rows }));
        } else {
            merge(&mut report, json!({ "per_view": per_view_json(&bands[0]) }));
            merge(
                &mut report,
                frame_json(&frame_backend, bands[0].gpu.as_ref()),
            );
        }
        outln!("{}", serde_json::to_string_pretty(&report)?)?;
        return Ok(());
    }
    outln!(
        "{} with {}: {} patches over {} triangles, level {} ({} views), {} bytes",
        args.mesh.display(),
        file.display(),
        pvis.patch_count(),
        mesh.triangle_count(),
        sampling.level,
        sampling.views,
        pvis.total_bytes()
    )?;
    if evaluator.shared_records() > 0 {
        outln!(
            "patches sharing their stored bounds with another: {} (matched in the order the \
             bake keeps them in; for a file numbered otherwise, evaluate its --mesh-out mesh)",
            evaluator.shared_records()
        )?;
    }
    let seeded = match views {
        Views::Random { seed, .. } => format!(", seed {seed}"),
        _ => String::new(),
    };
    if banded {
        outln!(
            "eval: {} views ({mode}{seeded}) at {resolution}x{resolution} px at each of {} distances ({seconds:.1} s)",
            bands[0].summary.views,
            bands.len(),
        )?;
        print_bands(&bands, &pvis)?;
        for band in &bands {
            if band.gpu.is_some() {
                outln!("distance x{}:", band.scale)?;
            }
            print_frame(&frame_backend, band.gpu.as_ref())?;
            if band.gpu.is_none() {
                // The same reason for every band.
                break;
            }
        }
    } else {
        let band = &bands[0];
        outln!(
            "eval: {} views ({mode}{seeded}) at {resolution}x{resolution} px, distance x{} ({seconds:.1} s)",
            band.summary.views,
            band.scale
        )?;
        print_summary(&band.summary, is_path)?;
        print_frame(&frame_backend, band.gpu.as_ref())?;
    }
    for path in &written {
        outln!("wrote {}", path.display())?;
    }
    Ok(())
}

/// The culling fields of `--stats`.
fn stats_culling_json(s: &EvalSummary) -> Value {
    json!({
        "answered_views": s.answered_views,
        "culling_rate_mean": s.culling_rate.mean,
        "frustum_culling_rate_mean": s.frustum_culling_rate.mean,
        "ideal_culling_rate_mean": s.ideal_culling_rate.mean,
        "ideal_culling_rate_all_directions_mean": s.ideal_culling_rate_all_directions.mean,
        "views_losing_a_patch_to_the_frustum": s.views_losing_a_patch_to_the_frustum,
    })
}

/// The `per_view` entries of a band, with the GPU's timings where measured.
fn per_view_json(band: &Band) -> Vec<Value> {
    band.metrics
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let mut view = view_json(i, m);
            if let Some(g) = &band.gpu {
                let (full, culled) = g.per_view_ms[i];
                merge(
                    &mut view,
                    json!({"gpu_full_ms": full, "gpu_culled_ms": culled}),
                );
            }
            view
        })
        .collect()
}

/// Opens MESH within the input's share of `memory`.
fn open_mesh(args: &EvalArgs, memory: MemoryBudget) -> Result<Mesh> {
    Ok(Mesh::open_with(
        &args.mesh,
        &patchvis::ooc::OpenOptions {
            memory_budget: memory.split().input,
            ..Default::default()
        },
    )?)
}

/// The picture directory: created if missing; anything else there is a usage error.
fn check_output_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(UsageError(format!(
            "--png {}: is a file, expected a directory",
            dir.display()
        ))
        .into());
    }
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))
}

fn path_cameras(path: &Path, center: &[f32; 3], fov: f32, resolution: u32) -> Result<Vec<Camera>> {
    // A FIFO would block the read, a device never end it.
    let metadata =
        std::fs::metadata(path).with_context(|| format!("{}: cannot read", path.display()))?;
    if !metadata.is_file() {
        return Err(anyhow!(
            "{}: not a regular file, expected a camera path file",
            path.display()
        ));
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let cameras =
        views::parse_camera_path(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    cameras
        .iter()
        .enumerate()
        .map(|(i, &PathCamera { eye, target })| {
            let target = target.unwrap_or(*center);
            if eye == target {
                return Err(anyhow!(
                    "{}: camera {}: the eye is at the model's centre, expected it elsewhere",
                    path.display(),
                    i + 1
                ));
            }
            Ok(Camera::look_at(eye, target, fov, resolution))
        })
        .collect()
}

/// Indices of the `n` views with the most missed pixels (ties: lower index first).
fn worst(metrics: &[ViewMetrics], n: u32) -> Vec<usize> {
    let mut order: Vec<usize> = (0..metrics.len()).collect();
    order.sort_by_key(|&i| (std::cmp::Reverse(metrics[i].missed_pixels), i));
    order.truncate(n as usize);
    order
}

fn write_png(path: &Path, image: &RgbImage) -> Result<()> {
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, image.width, image.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&image.pixels)?;
        writer.finish()?;
    }
    write_atomic(path, &bytes).with_context(|| format!("{}: cannot write", path.display()))
}

fn summary_fields(out: &mut serde_json::Map<String, Value>, name: &str, s: &Summary) {
    out.insert(format!("{name}_mean"), json!(s.mean));
    out.insert(format!("{name}_p95"), json!(s.p95));
    out.insert(format!("{name}_p99"), json!(s.p99));
    out.insert(format!("{name}_max"), json!(s.max));
    out.insert(format!("{name}_min"), json!(s.min));
}

/// The aggregate as flat JSON fields (`missed_pixels_mean`, …).
fn summary_json(s: &EvalSummary) -> Value {
    let mut out = serde_json::Map::new();
    out.insert("views".into(), json!(s.views));
    out.insert("answered_views".into(), json!(s.answered_views));
    out.insert("identical_views".into(), json!(s.identical_views));
    out.insert(
        "identical_views_fraction".into(),
        json!(s.identical_views_fraction()),
    );
    out.insert(
        "views_missing_a_patch".into(),
        json!(s.views_missing_a_patch),
    );
    summary_fields(&mut out, "missed_pixels", &s.missed_pixels);
    summary_fields(&mut out, "missed_patches", &s.missed_patches);
    summary_fields(&mut out, "triangles_drawn", &s.triangles_drawn);
    summary_fields(&mut out, "culling_rate", &s.culling_rate);
    summary_fields(&mut out, "ideal_culling_rate", &s.ideal_culling_rate);
    summary_fields(
        &mut out,
        "ideal_culling_rate_all_directions",
        &s.ideal_culling_rate_all_directions,
    );
    summary_fields(&mut out, "frustum_culling_rate", &s.frustum_culling_rate);
    out.insert(
        "views_losing_a_patch_to_the_frustum".into(),
        json!(s.views_losing_a_patch_to_the_frustum),
    );
    if let Some(p) = &s.psnr_db_differing {
        summary_fields(&mut out, "psnr_db_differing", p);
    }
    out.insert(
        "frame_cost".into(),
        json!({
            "full_ms_median": s.frame_cost.full_ms_median,
            "culled_ms_median": s.frame_cost.culled_ms_median,
            "speedup": s.frame_cost.speedup,
        }),
    );
    Value::Object(out)
}

fn view_json(index: usize, m: &ViewMetrics) -> Value {
    json!({
        "index": index,
        "eye": m.eye,
        "inside_sphere": m.inside_sphere,
        "covered_pixels": m.covered_pixels,
        "missed_pixels": m.missed_pixels,
        "tied_pixels": m.tied_pixels,
        "visible_patches": m.visible_patches,
        "answer_patches": m.answer_patches,
        "missed_patches": m.missed_patches,
        "triangles_drawn": m.triangles_drawn,
        "culling_rate": m.culling_rate,
        "ideal_culling_rate": m.ideal_culling_rate,
        "visible_patches_all_directions": m.visible_patches_all_directions,
        "ideal_culling_rate_all_directions": m.ideal_culling_rate_all_directions,
        "frustum_answer_patches": m.frustum_answer_patches,
        "frustum_triangles_drawn": m.frustum_triangles_drawn,
        "frustum_culling_rate": m.frustum_culling_rate,
        "frustum_lost_patches": m.frustum_lost_patches,
        // Infinite (identical pictures) becomes null.
        "psnr_db": m.psnr_db,
        "full_ms": 1e3 * m.full_seconds,
        "culled_ms": 1e3 * m.culled_seconds,
    })
}

fn merge(into: &mut Value, from: Value) {
    if let (Value::Object(a), Value::Object(b)) = (into, from) {
        a.extend(b);
    }
}

fn print_summary(s: &EvalSummary, is_path: bool) -> Result<(), StdoutError> {
    let unit = if is_path { "frames" } else { "views" };
    outln!(
        "{:<22}{:>12}{:>12}{:>12}{:>12}",
        "",
        "mean",
        "p95",
        "p99",
        "max"
    )?;
    let row = |name: &str, x: &Summary, percent: bool| {
        let f = |v: f64| {
            if percent {
                format!("{:.1}%", 100.0 * v)
            } else {
                format!("{v:.1}")
            }
        };
        outln!(
            "{name:<22}{:>12}{:>12}{:>12}{:>12}",
            f(x.mean),
            f(x.p95),
            f(x.p99),
            f(x.max)
        )
    };
    row("missed pixels", &s.missed_pixels, false)?;
    row("missed patches", &s.missed_patches, false)?;
    row("triangles drawn", &s.triangles_drawn, false)?;
    row("culling rate", &s.culling_rate, true)?;
    row("ideal culling", &s.ideal_culling_rate, true)?;
    row("culling + frustum", &s.frustum_culling_rate, true)?;
    outln!(
        "pixel-identical {unit}: {}/{} ({:.1}%); {unit} missing a visible patch: {}",
        s.identical_views,
        s.views,
        100.0 * s.identical_views_fraction(),
        s.views_missing_a_patch
    )?;
    if s.views_losing_a_patch_to_the_frustum > 0 {
        outln!(
            "{unit} where the frustum dropped a patch the answer draws: {} (a bug: please report)",
            s.views_losing_a_patch_to_the_frustum
        )?;
    }
    if let Some(p) = &s.psnr_db_differing {
        outln!(
            "PSNR of the {unit} that differ: mean {:.1} dB, worst {:.1} dB",
            p.mean,
            p.min
        )?;
    }
    outln!(
        "frame cost (CPU rasterizer, median per view): full {:.2} ms, culled {:.2} ms, speed-up {:.2}x",
        s.frame_cost.full_ms_median,
        s.frame_cost.culled_ms_median,
        s.frame_cost.speedup
    )
}

/// Missed pixels and PSNR per frame, and where a visible patch is missing.
fn path_plot(metrics: &[ViewMetrics]) -> String {
    let frames = |f: &dyn Fn(&ViewMetrics) -> f64| -> Vec<(f64, f64)> {
        metrics
            .iter()
            .enumerate()
            .map(|(i, m)| (i as f64, f(m)))
            .collect()
    };
    let popping = Chart {
        title: "Popping along the path".into(),
        x_label: "frame".into(),
        x_log: false,
        left_label: "missed pixels".into(),
        right_label: "missed patches".into(),
        series: vec![
            Series {
                name: "missed pixels".into(),
                points: frames(&|m| m.missed_pixels as f64),
                axis: Axis::Left,
                colour: 1,
            },
            Series {
                name: "missed visible patches".into(),
                points: frames(&|m| f64::from(m.missed_patches)),
                axis: Axis::Right,
                colour: 0,
            },
        ],
    };
    let quality = Chart {
        title: format!(
            "PSNR, shaded full vs reconstructed (identical frames at {PSNR_PLOT_CAP_DB} dB)"
        ),
        x_label: "frame".into(),
        x_log: false,
        left_label: "PSNR (dB)".into(),
        right_label: "culling rate (%)".into(),
        series: vec![
            Series {
                name: "PSNR".into(),
                points: frames(&|m| m.psnr_db.min(PSNR_PLOT_CAP_DB)),
                axis: Axis::Left,
                colour: 2,
            },
            Series {
                name: "culling rate".into(),
                points: frames(&|m| 100.0 * m.culling_rate),
                axis: Axis::Right,
                colour: 0,
            },
        ],
    };
    plot::svg(&[popping, quality])
}

fn run_sweep(args: &EvalArgs, distance_scale: f32) -> Result<()> {
    usage(args.views == 0, || "--views 0: expected at least 1".into())?;
    usage(args.sweep_patches.contains(&0), || {
        "--sweep-patches: expected patch counts of at least 1".into()
    })?;
    if let Some(&l) = args.sweep_levels.iter().find(|&&l| l > MAX_LEVEL) {
        return Err(UsageError(format!(
            "--sweep-levels: level {l}, expected 0 to {MAX_LEVEL}"
        ))
        .into());
    }
    usage(
        !(args.fov.is_finite() && args.fov > 0.0 && args.fov < 180.0),
        || {
            format!(
                "--fov {}: expected degrees between 0 and 180, exclusive",
                args.fov
            )
        },
    )?;
    let memory = memory_budget(args.memory);
    let settings = SweepSettings {
        patches: args.sweep_patches.clone(),
        levels: args.sweep_levels.clone(),
        bake: BakeSettings {
            rows: RowSettings {
                resolution: args.resolution.unwrap_or(DEFAULT_SWEEP_RESOLUTION),
                fov_deg: args.fov,
                // Plain: the stored views' own patches (`bake --view-supersample 0 --probe
                // off`); default: what a default `patchvis bake` writes at every level.
                research: Research {
                    view_supersample: match args.sweep_mode {
                        SweepModeArg::Plain => Some(0),
                        SweepModeArg::Default => None,
                    },
                    probe: match args.sweep_mode {
                        SweepModeArg::Plain => Probe::Off,
                        SweepModeArg::Default => Probe::Default,
                    },
                    ..Research::default()
                },
                ..RowSettings::default()
            },
            tiling: args.tiling.into(),
            memory,
            ..BakeSettings::default()
        },
        views: args.views,
        seed: args.seed,
        distance_scale,
    };
    let mode_name = match args.sweep_mode {
        SweepModeArg::Plain => "plain".to_string(),
        SweepModeArg::Default => format!(
            "as bake's default (--view-supersample {DEFAULT_VIEW_SUPERSAMPLE} --fold-min-pixels {DEFAULT_FOLD_MIN_PIXELS} --probe {DEFAULT_PROBE_PIXELS} --fold-corners {}, the probe off past {DEFAULT_PROBE_MAX_TRIANGLES} triangles)",
            match PROBE_FOLD_CORNERS {
                FoldCorners::All => "all",
                FoldCorners::One => "one",
                FoldCorners::Split => "split",
                FoldCorners::Cover => "cover",
            }
        ),
    };
    let mesh = open_mesh(args, memory)?;
    let bars = Bars::new(!args.quiet && !args.json);
    let start = Instant::now();
    let verbose = !args.quiet;
    let points = patchvis::eval::sweep(&mesh, &settings, &bars, &mut |p| {
        if verbose {
            eprintln!(
                "sweep: {} patches, level {}: culling {:.1}% (ideal {:.1}%), missed pixels {:.1} mean / {} p95 / {} max, identical {:.1}%, {} views missing a patch, {} bytes ({:.0} s)",
                p.patches,
                p.level,
                100.0 * p.summary.culling_rate.mean,
                100.0 * p.summary.ideal_culling_rate.mean,
                p.summary.missed_pixels.mean,
                p.summary.missed_pixels.p95,
                p.summary.missed_pixels.max,
                100.0 * p.summary.identical_views_fraction(),
                p.summary.views_missing_a_patch,
                p.file_bytes,
                start.elapsed().as_secs_f64()
            );
        }
    })
    .with_context(|| format!("{}: sweep failed", args.mesh.display()))?;

    let mut written = Vec::new();
    if let Some(dir) = &args.png {
        for (name, svg) in sweep_plots(&points) {
            let path = dir.join(name);
            write_atomic(&path, svg.as_bytes())
                .with_context(|| format!("{}: cannot write", path.display()))?;
            written.push(path);
        }
    }
    if args.json {
        let rows: Vec<Value> = points
            .iter()
            .map(|p| {
                let mut row = summary_json(&p.summary);
                merge(
                    &mut row,
                    json!({"patches": p.patches, "level": p.level, "sampling_views": p.sampling_views, "file_bytes": p.file_bytes}),
                );
                row
            })
            .collect();
        let report = json!({
            "mesh": args.mesh.display().to_string(),
            "triangles": mesh.triangle_count(),
            "resolution": settings.bake.rows.resolution,
            "fov_deg": settings.bake.rows.fov_deg,
            "views": settings.views,
            "seed": settings.seed,
            "distance_scale": settings.distance_scale,
            "sweep_mode": mode_name,
            "seconds": start.elapsed().as_secs_f64(),
            "points": rows,
            "pictures": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        });
        outln!("{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        outln!(
            "{}: {} triangles; {} random views (seed {}) at {} px; bakes sampled {mode_name}",
            args.mesh.display(),
            mesh.triangle_count(),
            settings.views,
            settings.seed,
            settings.bake.rows.resolution
        )?;
        outln!(
            "| patches | level | views | file bytes | culling | ideal culling | identical views | views with a miss | missed px mean / p95 / max |"
        )?;
        outln!("|---|---|---|---|---|---|---|---|---|")?;
        for p in &points {
            let s = &p.summary;
            outln!(
                "| {} | {} | {} | {} | {:.1}% | {:.1}% | {:.1}% | {}/{} | {:.1} / {} / {} |",
                p.patches,
                p.level,
                p.sampling_views,
                p.file_bytes,
                100.0 * s.culling_rate.mean,
                100.0 * s.ideal_culling_rate.mean,
                100.0 * s.identical_views_fraction(),
                s.views - s.identical_views,
                s.views,
                s.missed_pixels.mean,
                s.missed_pixels.p95,
                s.missed_pixels.max
            )?;
        }
        for path in &written {
            outln!("wrote {}", path.display())?;
        }
    }
    Ok(())
}

/// The seed paper's Figures 4–5 for this mesh: culling rate and missed pixels against the
/// number of sampling views (one line per patch count) and against the patch count (one line
/// per level), with the file size on the right axis.
fn sweep_plots(points: &[SweepPoint]) -> Vec<(&'static str, String)> {
    let mut patches: Vec<u32> = points.iter().map(|p| p.patches).collect();
    patches.sort_unstable();
    patches.dedup();
    let mut levels: Vec<u32> = points.iter().map(|p| p.level).collect();
    levels.sort_unstable();
    levels.dedup();
    type Metric = fn(&SweepPoint) -> f64;
    let culling: Metric = |p| 100.0 * p.summary.culling_rate.mean;
    let missed: Metric = |p| p.summary.missed_pixels.mean;
    let size: Metric = |p| p.file_bytes as f64 / 1024.0;
    let chart = |by_level: bool, what: &str, metric: Metric, label: &str| {
        let groups: Vec<u32> = if by_level {
            patches.clone()
        } else {
            levels.clone()
        };
        let mut series = Vec::new();
        for (axis, f, suffix) in [(Axis::Left, metric, ""), (Axis::Right, size, " size")] {
            for (c, &g) in groups.iter().enumerate() {
                let pts = points
                    .iter()
                    .filter(|p| {
                        if by_level {
                            p.patches == g
                        } else {
                            p.level == g
                        }
                    })
                    .map(|p| {
                        let x = if by_level {
                            f64::from(p.sampling_views)
                        } else {
                            f64::from(p.patches)
                        };
                        (x, f(p))
                    })
                    .collect();
                let name = if by_level {
                    format!("P={g}{suffix}")
                } else {
                    format!("level {g}{suffix}")
                };
                series.push(Series {
                    name,
                    points: pts,
                    axis,
                    colour: c,
                });
            }
        }
        Chart {
            title: format!(
                "{what} against {}",
                if by_level {
                    "sampling views"
                } else {
                    "patch count"
                }
            ),
            x_label: if by_level {
                "sampling views (sphere levels)".into()
            } else {
                "patches".into()
            },
            x_log: true,
            left_label: label.into(),
            right_label: "file size (KiB), dashed".into(),
            series,
        }
    };
    vec![
        (
            "sweep-levels.svg",
            plot::svg(&[
                chart(true, "Culling rate", culling, "culling rate (%)"),
                chart(
                    true,
                    "Missed pixels",
                    missed,
                    "missed pixels per view (mean)",
                ),
            ]),
        ),
        (
            "sweep-patches.svg",
            plot::svg(&[
                chart(false, "Culling rate", culling, "culling rate (%)"),
                chart(
                    false,
                    "Missed pixels",
                    missed,
                    "missed pixels per view (mean)",
                ),
            ]),
        ),
    ]
}
