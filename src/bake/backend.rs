//! Where a bake renders its ID buffers, as a value: the CPU rasterizer (bit-exact and
//! reproducible everywhere, the default) or the wgpu backend (feature `gpu`). `Auto` takes a
//! hardware GPU when there is one and says why it did not otherwise.

use super::{BakeError, BakeSettings};
use crate::progress::Progress;
use crate::sampler::{self, SamplingOptions, Scene};
use crate::visibility::{SamplingParams, VisibilityMatrix};

/// Which backend to open (`--backend`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackendChoice {
    /// The CPU rasterizer.
    #[default]
    Cpu,
    /// The GPU; an error without an adapter or the `gpu` feature.
    Gpu,
    /// A hardware GPU if there is one, else the CPU.
    Auto,
}

/// An opened sampling backend.
#[derive(Debug)]
pub enum Backend {
    /// The CPU rasterizer (`sampler::sample_tiled`).
    Cpu,
    /// An open GPU device with its pipelines.
    #[cfg(feature = "gpu")]
    Gpu(Box<sampler::gpu::GpuSampler>),
}

/// The first option of `settings` the GPU backend does not implement, if any.
pub(crate) fn cpu_only_option(settings: &BakeSettings) -> Option<&'static str> {
    let research = &settings.rows.research;
    if settings.rows.preset == super::Preset::Conservative {
        Some("--conservative")
    } else if matches!(research.probe, super::Probe::Pixels(_)) {
        Some("--probe")
    } else if research.apertures.is_some_and(|px| px > 0) {
        Some("--apertures")
    } else if research.conservative_raster {
        Some("--conservative-raster")
    } else if settings.resume {
        Some("--resume")
    } else if research.finer_views == Some(crate::sampler::FinerViews::Centroids) {
        Some("--finer-views centroids")
    } else {
        None
    }
}

impl Backend {
    /// Opens `choice` for a bake with `settings`, some of whose options only the CPU
    /// implements (`cpu_only_option`). `Auto` falls back to the CPU and returns why as the
    /// second value (a software rasterizer such as lavapipe is slower than the CPU backend).
    pub fn open(
        choice: BackendChoice,
        settings: &BakeSettings,
    ) -> Result<(Backend, Option<String>), BakeError> {
        match choice {
            BackendChoice::Cpu => Ok((Backend::Cpu, None)),
            BackendChoice::Gpu => {
                if let Some(option) = cpu_only_option(settings) {
                    return Err(BakeError::Settings(format!(
                        "--backend gpu: {option} needs the CPU backend (--backend cpu or auto)"
                    )));
                }
                #[cfg(feature = "gpu")]
                {
                    sampler::gpu::GpuSampler::new()
                        .map(|g| (Backend::Gpu(Box::new(g)), None))
                        .map_err(|e| BakeError::Backend(format!("--backend gpu: {e}")))
                }
                #[cfg(not(feature = "gpu"))]
                Err(BakeError::Settings(
                    "--backend gpu: this patchvis was built without the `gpu` feature".into(),
                ))
            }
            BackendChoice::Auto => {
                let why_cpu = if let Some(option) = cpu_only_option(settings) {
                    format!("{option} needs it")
                } else {
                    #[cfg(feature = "gpu")]
                    match sampler::gpu::GpuSampler::new() {
                        Ok(g) if !g.is_software() => {
                            return Ok((Backend::Gpu(Box::new(g)), None));
                        }
                        Ok(g) => format!("{} is a software rasterizer", g.adapter()),
                        Err(e) => e.to_string(),
                    }
                    #[cfg(not(feature = "gpu"))]
                    "built without the `gpu` feature".to_string()
                };
                Ok((Backend::Cpu, Some(why_cpu)))
            }
        }
    }

    /// `cpu`, or `gpu: ADAPTER`.
    pub fn describe(&self) -> String {
        match self {
            Backend::Cpu => "cpu".into(),
            #[cfg(feature = "gpu")]
            Backend::Gpu(g) => format!("gpu: {}", g.adapter()),
        }
    }

    /// Whether this is the CPU rasterizer.
    pub fn is_cpu(&self) -> bool {
        matches!(self, Backend::Cpu)
    }

    /// Samples every view of `params` for the patches of the scene's tiling: the sampling
    /// sphere's, or a shell's views (`options.shell`), on either backend. The CPU sampler
    /// builds its set-up in `scene` on the first pass and reuses it on the next.
    pub fn sample(
        &self,
        scene: &Scene,
        params: &SamplingParams,
        options: &SamplingOptions,
        progress: &dyn Progress,
    ) -> Result<VisibilityMatrix, BakeError> {
        match self {
            Backend::Cpu => Ok(sampler::sample_scene(scene, params, options, progress)?),
            #[cfg(feature = "gpu")]
            Backend::Gpu(gpu) => gpu
                .sample(scene.mesh(), scene.tiling(), params, options, progress)
                .map_err(|e| BakeError::Backend(format!("GPU sampling failed: {e}"))),
        }
    }

    /// [`Backend::sample`], also returning the rows before the probe pass
    /// (`sampler::sample_tiled_split`, for the split fold of `--conservative`). CPU only, as
    /// the probe pass is: [`Backend::open`] refuses `--conservative` on the GPU.
    pub fn sample_split(
        &self,
        scene: &Scene,
        params: &SamplingParams,
        options: &SamplingOptions,
        progress: &dyn Progress,
    ) -> Result<(VisibilityMatrix, VisibilityMatrix), BakeError> {
        match self {
            Backend::Cpu => Ok(sampler::sample_scene_split(
                scene, params, options, progress,
            )?),
            #[cfg(feature = "gpu")]
            Backend::Gpu(_) => Err(BakeError::Backend(
                "the split fold (--conservative) samples on the CPU backend only".into(),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::FinerViews;

    #[test]
    fn the_gpu_refuses_what_only_the_cpu_sampler_does() {
        let with = |f: fn(&mut BakeSettings)| {
            let mut s = BakeSettings::default();
            f(&mut s);
            cpu_only_option(&s)
        };
        assert_eq!(with(|_| {}), None);
        assert_eq!(
            with(|s| s.rows.preset = crate::bake::Preset::Conservative),
            Some("--conservative")
        );
        assert_eq!(
            with(|s| s.rows.research.finer_views = Some(FinerViews::Centroids)),
            Some("--finer-views centroids")
        );
        let mut centroids = BakeSettings::default();
        centroids.rows.research.finer_views = Some(FinerViews::Centroids);
        let err = Backend::open(BackendChoice::Gpu, &centroids).unwrap_err();
        assert!(err.to_string().contains("--finer-views centroids"), "{err}");
    }
}
