use super::*;
use crate::bake::BakeSettings;

/// The plan of the default bake changed by `f`, with checkpoints beside `out.pvis`.
fn plan(f: impl FnOnce(&mut RowSettings)) -> Result<Plan, SettingsError> {
    let mut rows = RowSettings::default();
    f(&mut rows);
    Plan::new(rows)
}

fn checkpoints(plan: &Plan) -> Vec<PassCheckpoints> {
    plan.checkpoints(Some(Path::new("out.pvis")))
}

fn fine(plan: &Plan) -> Option<PathBuf> {
    checkpoints(plan)[0].fine.clone()
}

fn coarse(plan: &Plan) -> Option<PathBuf> {
    checkpoints(plan)[0].coarse.clone()
}

#[test]
fn supersampling_defaults_follow_the_level_and_the_preset() {
    let c = plan(|_| {}).unwrap();
    assert_eq!(
        c.main.supersample,
        Supersample {
            extra_levels: DEFAULT_VIEW_SUPERSAMPLE,
            fold_min_pixels: 0,
            fold_corners: FoldCorners::Cover,
            finer: FinerViews::Midpoints,
        }
    );
    assert_eq!((c.level(), c.rows.resolution), (DEFAULT_LEVEL, 512));
    // The probe pass at 1 pixel, and the cover fold.
    assert_eq!(c.main.probe, Some(DEFAULT_PROBE_PIXELS));
    // One pass: the finer views' rows hold the stored ones as their prefix.
    assert_eq!(fine(&c), Some("out.pvis.vs1.ckpt".into()));
    assert_eq!(coarse(&c), None);
    // A threshold samples the stored level plainly once more, with a checkpoint of its own,
    // and the finer pass's checkpoint names the threshold.
    let c = plan(|s| s.research.fold_min_pixels = Some(4)).unwrap();
    assert_eq!(c.main.supersample.fold_min_pixels, 4);
    assert_eq!(fine(&c), Some("out.pvis.vs1.m4.ckpt".into()));
    assert_eq!(coarse(&c), Some("out.pvis.ckpt".into()));
    // The finest level has nothing finer to sample: the default turns itself off there,
    // while asking for it explicitly is an error.
    let c = plan(|s| s.level = Some(7)).unwrap();
    assert_eq!(
        (
            c.main.supersample.extra_levels,
            c.main.supersample.fold_min_pixels
        ),
        (0, 0)
    );
    assert_eq!(fine(&c), Some("out.pvis.ckpt".into()));
    let err = plan(|s| {
        s.level = Some(7);
        s.research.view_supersample = Some(1)
    })
    .unwrap_err();
    assert!(err.0.contains("--view-supersample 1"), "{}", err.0);
}

#[test]
fn the_conservative_preset_expands_in_one_place() {
    let c = Plan::new(BakeSettings::conservative().rows).unwrap();
    assert_eq!(c.level(), CONSERVATIVE_LEVEL);
    assert_eq!(
        (
            c.main.supersample.extra_levels,
            c.main.supersample.fold_min_pixels
        ),
        (DEFAULT_VIEW_SUPERSAMPLE, 0)
    );
    assert_eq!(c.main.probe, Some(CONSERVATIVE_PROBE_PIXELS));
    assert!(!c.default_probe);
    // The centroids of the stored faces for finer views, and the split fold: the finer pass
    // keeps its seen rows, in a checkpoint of its own.
    assert_eq!(c.main.supersample.finer, FinerViews::Centroids);
    let suffix = format!(".p{CONSERVATIVE_PROBE_PIXELS}.vs1.centroids.split.ckpt");
    assert_eq!(fine(&c), Some(format!("out.pvis{suffix}").into()));
    assert_eq!(c.main.supersample.fold_corners, FoldCorners::Split);
    assert_eq!(c.pass_levels()[..2], [6, 6]);
    // The shells stay at the default level, with the vertices for finer views.
    assert_eq!(c.shell.level, DEFAULT_LEVEL);
    assert_eq!(c.shell.supersample.finer, FinerViews::Midpoints);
    // Its level, finer views and shell level given: as given.
    let given = plan(|s| {
        s.preset = Preset::Conservative;
        s.level = Some(3);
        s.shell_level = Some(5);
        s.research.finer_views = Some(FinerViews::Midpoints)
    })
    .unwrap();
    assert_eq!(
        (
            given.level(),
            given.shell.level,
            given.main.supersample.finer
        ),
        (3, 5, FinerViews::Midpoints)
    );
    // A level with no finer one keeps the vertices.
    let finest = plan(|s| {
        s.preset = Preset::Conservative;
        s.level = Some(MAX_LEVEL)
    })
    .unwrap();
    assert_eq!(
        (
            finest.main.supersample.extra_levels,
            finest.main.supersample.finer
        ),
        (0, FinerViews::Midpoints)
    );
    // With --probe: refused.
    let err = plan(|s| {
        s.preset = Preset::Conservative;
        s.research.probe = Probe::Pixels(1)
    })
    .unwrap_err();
    assert!(err.0.contains("--probe with --conservative"), "{}", err.0);
}

#[test]
fn the_probe_decides_the_fold() {
    // Split without the probe, or with a fold threshold: refused.
    let err = plan(|s| {
        s.research.probe = Probe::Off;
        s.research.fold_corners = Some(FoldCorners::Split)
    })
    .unwrap_err();
    assert!(
        err.0.contains("expected --conservative or --probe"),
        "{}",
        err.0
    );
    let err = plan(|s| {
        s.preset = Preset::Conservative;
        s.research.fold_min_pixels = Some(4);
        s.research.fold_corners = Some(FoldCorners::Split)
    })
    .unwrap_err();
    assert!(err.0.contains("no fold threshold"), "{}", err.0);
    let c = plan(|s| s.research.probe = Probe::Off).unwrap();
    assert_eq!(
        (c.main.probe, c.main.supersample.fold_corners),
        (None, UNPROBED_FOLD_CORNERS)
    );
    // Named as the default's: neither names its probe.
    assert_eq!(fine(&c), Some("out.pvis.vs1.ckpt".into()));
    // --probe: the probe pass alone, with the cover fold and one pass; the split fold is its
    // own to ask for.
    let c = plan(|s| s.research.probe = Probe::Pixels(1)).unwrap();
    assert_eq!(c.main.probe, Some(1));
    assert_eq!(c.main.supersample.fold_corners, FoldCorners::Cover);
    assert_eq!(c.pass_levels(), plan(|_| {}).unwrap().pass_levels());
    assert_eq!(fine(&c), Some("out.pvis.p1.vs1.ckpt".into()));
    let c = plan(|s| {
        s.research.probe = Probe::Pixels(0);
        s.research.fold_corners = Some(FoldCorners::Split)
    })
    .unwrap();
    assert_eq!(
        (c.main.probe, c.pass_levels()[..2].to_vec()),
        (Some(0), vec![5, 5])
    );
    // A threshold at or below --min-pixels changes nothing: no extra plain pass.
    let c = plan(|s| {
        s.research.min_pixels = 4;
        s.research.probe = Probe::Off;
        s.research.fold_min_pixels = Some(4)
    })
    .unwrap();
    assert_eq!((c.main.supersample.fold_min_pixels, coarse(&c)), (0, None));
    let c = plan(|s| {
        s.research.view_supersample = Some(0);
        s.research.fold_min_pixels = Some(9)
    })
    .unwrap();
    assert_eq!(
        (
            c.main.supersample.extra_levels,
            c.main.supersample.fold_min_pixels
        ),
        (0, 0)
    );
}

#[test]
fn centroid_finer_views_need_one_finer_level_and_leave_the_shells_alone() {
    let c = plan(|s| {
        s.research.finer_views = Some(FinerViews::Centroids);
        s.shells = 1
    })
    .unwrap();
    assert_eq!(c.main.supersample.finer, FinerViews::Centroids);
    assert_eq!(c.shell.supersample.finer, FinerViews::Midpoints);
    assert_eq!(fine(&c), Some("out.pvis.vs1.centroids.ckpt".into()));
    for k in [0, 2] {
        let err = plan(|s| {
            s.research.finer_views = Some(FinerViews::Centroids);
            s.research.view_supersample = Some(k)
        })
        .unwrap_err();
        assert!(
            err.0.contains(&format!(
                "--finer-views centroids with --view-supersample {k}"
            )),
            "{}",
            err.0
        );
    }
    // At the finest level there is no finer one.
    assert!(
        plan(|s| {
            s.research.finer_views = Some(FinerViews::Centroids);
            s.level = Some(MAX_LEVEL)
        })
        .is_err()
    );
}

#[test]
fn every_shell_has_checkpoints_of_its_own_and_the_stored_levels_fold() {
    let c = plan(|_| {}).unwrap();
    // The default's probe and cover fold run on the shells too.
    assert_eq!(c.shell.supersample, c.main.supersample);
    assert_eq!(c.shell.supersample.fold_corners, PROBE_FOLD_CORNERS);
    assert_eq!(c.shell.probe, Some(DEFAULT_PROBE_PIXELS));
    assert_eq!(c.shell.level, 4);
    let all = checkpoints(&c);
    let near = shells::DEFAULT_SHELLS as usize;
    assert_eq!(all.len(), 1 + near + shells::DEFAULT_FAR_SHELLS.len());
    for (s, pass) in all.iter().enumerate().skip(1) {
        let name = match s <= near {
            true => format!("out.pvis.shell{s}.vs1.ckpt"),
            false => format!("out.pvis.far{}.vs1.ckpt", s - near),
        };
        assert_eq!(
            *pass,
            PassCheckpoints {
                coarse: None,
                fine: Some(name.into()),
            }
        );
    }
    // A thresholded fold: two passes per shell, each with a checkpoint.
    let c = plan(|s| {
        s.research.fold_min_pixels = Some(4);
        s.preset = Preset::Conservative;
        s.level = Some(4);
        s.shells = 1;
        s.far_shells = Vec::new()
    })
    .unwrap();
    assert_eq!(
        checkpoints(&c)[1],
        PassCheckpoints {
            coarse: Some("out.pvis.shell1.p1.ckpt".into()),
            fine: Some("out.pvis.shell1.p1.vs1.m4.ckpt".into()),
        }
    );
    assert_eq!(c.pass_levels(), vec![4, 5, 4, 5]);
    // The shells' own level, its supersampling capped at the finest level.
    let c = plan(|s| s.shell_level = Some(MAX_LEVEL)).unwrap();
    assert_eq!(c.shell.level, MAX_LEVEL);
    assert_eq!(c.shell.supersample.extra_levels, 0);
    assert_eq!(checkpoints(&c)[1].fine, Some("out.pvis.shell1.ckpt".into()));
    // The sampling sphere's fold level, then each shell's own, near and far.
    let mut levels = vec![5];
    levels.extend([MAX_LEVEL; shells::DEFAULT_SHELLS as usize]);
    levels.extend([MAX_LEVEL; shells::DEFAULT_FAR_SHELLS.len()]);
    assert_eq!(c.pass_levels(), levels);
    // No shells: the sampling sphere's passes alone.
    let c = plan(|s| {
        s.shells = 0;
        s.far_shells = Vec::new()
    })
    .unwrap();
    assert_eq!(checkpoints(&c).len(), 1);
    assert_eq!(c.pass_levels(), vec![5]);
}

#[test]
fn the_default_probe_turns_itself_off_where_it_cannot_run() {
    use crate::memory::DEFAULT_PROBE_MAX_TRIANGLES;
    let memory = MemoryBudget::new(256 << 20);
    let default = plan(|_| {}).unwrap();
    assert_eq!(
        (default.main.probe, default.shell.probe),
        (Some(1), Some(1))
    );
    // Up to the bound on the CPU: as it is, on every machine (256 MiB is the smallest default
    // budget, and the bound's solids fit it).
    assert!(
        default
            .for_mesh(DEFAULT_PROBE_MAX_TRIANGLES, true, memory)
            .is_none()
    );
    let off = plan(|s| s.research.probe = Probe::Off).unwrap();
    for (triangles, cpu, why) in [
        (DEFAULT_PROBE_MAX_TRIANGLES + 1, true, "past the 2236962"),
        (1000, false, "the GPU backend"),
    ] {
        let (turned, message) = default.for_mesh(triangles, cpu, memory).unwrap();
        assert!(message.contains(why), "{message}");
        // The plan of --probe off, with the same checkpoints.
        assert_eq!(turned, off);
        assert_eq!(turned.main.supersample.fold_corners, FoldCorners::All);
        assert_eq!(checkpoints(&turned), checkpoints(&default));
        assert!(turned.for_mesh(triangles, cpu, memory).is_none());
    }
    // A smaller --memory than its solids need.
    let (turned, message) = default
        .for_mesh(1_000_000, true, MemoryBudget::new(16 << 20))
        .unwrap();
    assert!(message.contains("--memory 16 MiB"), "{message}");
    assert_eq!(turned.main.probe, None);
    // An explicit fold stays; what was asked for is never turned off.
    let cover = plan(|s| s.research.fold_corners = Some(FoldCorners::Cover)).unwrap();
    let (turned, _) = cover.for_mesh(1000, false, memory).unwrap();
    assert_eq!(turned.main.supersample.fold_corners, FoldCorners::Cover);
    for asked in [
        plan(|s| s.research.probe = Probe::Pixels(1)).unwrap(),
        plan(|s| s.preset = Preset::Conservative).unwrap(),
        plan(|s| s.research.fold_corners = Some(FoldCorners::Split)).unwrap(),
        off,
    ] {
        assert!(
            asked.for_mesh(u32::MAX, false, memory).is_none(),
            "{:?}",
            asked.rows
        );
    }
}

#[test]
fn the_spheres_lie_at_the_shells_and_answer_their_bands() {
    let params = shells::tests::params(2.0);
    let c = plan(|_| {}).unwrap();
    let spheres = c.spheres(&params, None).unwrap();
    let distances = c.shell_distances(&params).unwrap();
    let far = c.far_distances(&params).unwrap();
    let d = params.distance();
    assert_eq!(far, [2.0, 256.0].map(|f| (f64::from(d) * f) as f32));
    assert_eq!(spheres.len(), 1 + distances.len() + far.len());
    assert_eq!(spheres[0].kind, SphereKind::Sampling);
    assert_eq!(spheres[0].shell, None);
    for (s, sphere) in spheres.iter().enumerate().skip(1) {
        let (kind, distance) = match s.checked_sub(distances.len() + 1) {
            None => (SphereKind::Shell(s as u32), distances[s - 1]),
            Some(j) => (SphereKind::Far(j as u32 + 1), far[j]),
        };
        assert_eq!(sphere.kind, kind);
        assert_eq!(sphere.shell, Some(distance));
        assert_eq!(sphere.params.level, c.shell.level);
        // The default's probe cells lie at each view's own distance.
        assert_eq!(sphere.probe_band, None);
    }
    // The file's records: the far band outermost first, then the shells inside.
    let file = c.file_shell_distances(&params).unwrap();
    assert!(file.windows(2).all(|w| w[0] > w[1]), "{file:?}");
    assert_eq!(file.len(), far.len() + distances.len());
    // Another probe spans the band to the next sphere in and out; the sampling sphere's stops
    // at its own distance, and the far band's innermost starts there.
    let asked = plan(|s| s.research.probe = Probe::Pixels(1)).unwrap();
    let spheres = asked.spheres(&params, None).unwrap();
    let bands = shells::bands(d, &distances)
        .into_iter()
        .chain(shells::far_bands(d, &far));
    for (sphere, band) in spheres.iter().zip(bands) {
        assert_eq!(sphere.probe_band, band);
    }
    assert_eq!(spheres[0].probe_band, Some([distances[0], d]));
    let last = spheres.last().unwrap().probe_band;
    assert_eq!(last, Some([far[0], far[1]]));
    assert_eq!(spheres[3].probe_band, Some([d, far[1]]));
}

#[test]
fn min_pixels_under_a_probe_pass_is_refused() {
    for probe in [Probe::Default, Probe::Pixels(2)] {
        let err = plan(|s| {
            s.research.min_pixels = 2;
            s.research.probe = probe
        })
        .unwrap_err();
        assert!(
            err.0.starts_with("--min-pixels 2:") && err.0.contains("--probe off"),
            "{}",
            err.0
        );
    }
    // 0 and 1 mean any pixel: no threshold to defeat.
    assert!(plan(|s| s.research.min_pixels = 1).is_ok());
    assert!(
        plan(|s| {
            s.research.min_pixels = 2;
            s.research.probe = Probe::Off
        })
        .is_ok()
    );
}

#[test]
fn the_sampling_reach_is_where_the_finest_probe_cells_hold() {
    let c = plan(|_| {}).unwrap();
    // A sampling sphere at 4, with a far shell at 8.
    let reach = c.sampling_reach(4.0, &[8.0, 3.0]);
    assert!(reach > 4.0 * 1.011 && reach < 4.0 * 1.012, "{reach}");
    // The finest pass's cells, rounded down to binary32.
    let fine = DEFAULT_LEVEL + DEFAULT_VIEW_SUPERSAMPLE;
    let exact = 4.0 * probe_reach(&PassViews::pass(fine, c.main.supersample.finer));
    assert!(f64::from(reach) <= exact && f64::from(reach.next_up()) > exact);
    // None without a far shell or without the probe.
    assert_eq!(c.sampling_reach(4.0, &[3.0, 2.0]), 0.0);
    assert_eq!(c.sampling_reach(4.0, &[]), 0.0);
    let off = plan(|s| s.research.probe = Probe::Off).unwrap();
    assert_eq!(off.sampling_reach(4.0, &[8.0]), 0.0);
    // `--conservative` probes too.
    let conservative = plan(|s| s.preset = Preset::Conservative).unwrap();
    assert!(conservative.sampling_reach(4.0, &[8.0]) > 4.0);
}
