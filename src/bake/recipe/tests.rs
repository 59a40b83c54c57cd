use super::*;
use crate::bake::{Outputs, PatchOrder, Probe, Research, RowSettings, shells};
use crate::progress::NoProgress;
use crate::sphere::view_count;
use crate::test_kit::bunny::bunny;

/// The default bake's shells lie at the documented radii, are sampled like the
/// sampling sphere (its supersampling), the same on one thread and two, and follow the
/// sampling sphere's patch numbering.
#[test]
fn shells_lie_at_their_radii_and_follow_the_sampling_spheres_numbering() {
    let mesh = bunny();
    let recipe = |patch_order| {
        BakeSettings {
            patches: 80,
            rows: RowSettings {
                level: Some(1),
                resolution: 32,
                patch_order,
                ..RowSettings::default()
            },
            ..BakeSettings::default()
        }
        .check()
        .unwrap()
    };
    let bake = |patch_order, threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            recipe(patch_order)
                .run(&mesh, &Backend::Cpu, &NoProgress, &mut Stages::new())
                .unwrap()
        })
    };
    let spatial = bake(PatchOrder::Spatial, 2);
    let (d, r) = (
        f64::from(spatial.params.distance()),
        f64::from(spatial.params.radius),
    );
    // The far band's shells first, outermost first, then the near ones.
    let far = shells::DEFAULT_FAR_SHELLS.len();
    assert_eq!(spatial.shells.len(), far + shells::DEFAULT_SHELLS as usize);
    for (j, shell) in spatial.shells[..far].iter().enumerate() {
        let expected = (d * shells::DEFAULT_FAR_SHELLS[far - 1 - j]) as f32;
        assert_eq!(shell.distance, expected, "far shell {j}");
        assert_eq!(shell.visibility.views(), view_count(1));
        assert_eq!(shell.sampled_views, view_count(2));
    }
    for (s, shell) in spatial.shells[far..].iter().enumerate() {
        let expected =
            (d * (1.1 * r / d).powf((s + 1) as f64 / f64::from(shells::DEFAULT_SHELLS))) as f32;
        assert!(
            (shell.distance - expected).abs() <= expected * f32::EPSILON,
            "shell {s}: {} vs {expected}",
            shell.distance
        );
        assert_eq!(shell.visibility.views(), view_count(1));
        assert_eq!(shell.sampled_views, view_count(2));
    }
    assert_eq!(spatial.sampled_views, view_count(2));
    let (one, two) = (
        bake(PatchOrder::Covisibility, 1),
        bake(PatchOrder::Covisibility, 2),
    );
    assert_eq!(one.bytes, two.bytes);
    let order = encode::file_patch_order(
        PatchOrder::Covisibility,
        &spatial.tiling.patches,
        &spatial.visibility,
    )
    .expect("renumbered by co-visibility");
    assert_eq!(one.visibility, spatial.visibility.with_patch_order(&order));
    for ((a, b), s) in one.shells.iter().zip(&two.shells).zip(&spatial.shells) {
        assert_eq!((a.distance, &a.visibility), (b.distance, &b.visibility));
        assert_eq!(a.distance, s.distance);
        assert_eq!(a.visibility, s.visibility.with_patch_order(&order));
    }
}

/// Every pass, each shell's included, checkpoints beside the output; a bake resumed
/// from them (one shell's missing, so sampled again) gives the same bytes and shells.
#[test]
fn every_pass_checkpoints_and_a_resumed_bake_gives_the_same_file() {
    let mesh = bunny();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b.pvis");
    let recipe = |resume| {
        BakeSettings {
            patches: 60,
            rows: RowSettings {
                level: Some(1),
                resolution: 32,
                shells: 2,
                research: Research {
                    fold_min_pixels: Some(4),
                    probe: Probe::Off,
                    ..Research::default()
                },
                ..RowSettings::default()
            },
            checkpoint: Some(out.clone()),
            resume,
            ..BakeSettings::default()
        }
        .check()
        .unwrap()
    };
    let first = recipe(false)
        .run(&mesh, &Backend::Cpu, &NoProgress, &mut Stages::new())
        .unwrap();
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "b.pvis.ckpt",
            "b.pvis.far1.ckpt",
            "b.pvis.far1.vs1.m4.ckpt",
            "b.pvis.far2.ckpt",
            "b.pvis.far2.vs1.m4.ckpt",
            "b.pvis.shell1.ckpt",
            "b.pvis.shell1.vs1.m4.ckpt",
            "b.pvis.shell2.ckpt",
            "b.pvis.shell2.vs1.m4.ckpt",
            "b.pvis.vs1.m4.ckpt"
        ]
    );
    std::fs::remove_file(dir.path().join("b.pvis.shell2.vs1.m4.ckpt")).unwrap();
    let resumed = recipe(true)
        .run(&mesh, &Backend::Cpu, &NoProgress, &mut Stages::new())
        .unwrap();
    assert_eq!(resumed.bytes, first.bytes);
    for (a, b) in resumed.shells.iter().zip(&first.shells) {
        assert_eq!((a.distance, &a.visibility), (b.distance, &b.visibility));
    }
    // Written out, the bake removes every checkpoint.
    let outputs = Outputs {
        pvis: out.clone(),
        mesh: None,
    };
    recipe(true)
        .write(&resumed, &mesh, &outputs, &mut Stages::new())
        .unwrap();
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["b.pvis"]);
}
