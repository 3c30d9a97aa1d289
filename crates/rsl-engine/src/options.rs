//! What an engine is asked to prepare: its layers and options, the BRDF a scene material
//! names and its content key, the visibility fields' and tables' parameters for a quality,
//! and the bound on what one preparation may allocate.

use crate::progress::Progress;
use anyhow::{Result, bail};
use rsl_brdf::{Brdf, Resolution};
use rsl_scene::{Preset, QualitySettings};
use rsl_vis::{OvdfParams, SvdfParams};
use std::path::PathBuf;

/// Which layers of prepared data an engine builds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layers {
    /// The RSL path's data: light set, BRDF tables, visibility fields. Without it only the
    /// method-neutral layer is prepared (what the Monte Carlo truth needs).
    pub rsl: bool,
}

impl Default for Layers {
    fn default() -> Self {
        Self { rsl: true }
    }
}

/// How the engine prepares a scene.
#[derive(Clone, Debug, Default)]
pub struct EngineOptions {
    /// Disk cache folder; `None`: memory only.
    pub cache_dir: Option<PathBuf>,
    /// Overrides the scene's RSL count.
    pub rsl_count: Option<u32>,
    /// Overrides the scene's quality preset (the scene's own knob overrides are dropped).
    pub quality: Option<Preset>,
    /// Where long steps (decomposition, field builds) report their progress.
    pub progress: Progress,
    /// Bytes of rebuildable prepared data kept in memory beyond what the scene uses
    /// (`None`: [`DEFAULT_BUDGET`]).
    pub memory_budget: Option<usize>,
    /// The layers to prepare.
    pub layers: Layers,
    /// Bytes rsl's files in the cache folder may take in all before the least recently
    /// used are removed ([`crate::cache::trim`]); `None`: `$RSL_CACHE_MAX_MB` megabytes,
    /// else [`crate::cache::DEFAULT_MAX_MB`]; `u64::MAX`: no limit.
    pub cache_limit: Option<u64>,
}

/// The self-visibility resolution of a quality setting.
pub fn svdf_params(preset: Preset, q: &QualitySettings) -> SvdfParams {
    let base = match preset {
        Preset::Draft => SvdfParams::DRAFT,
        Preset::Standard | Preset::Paper => SvdfParams::PAPER,
        Preset::High => SvdfParams::HIGH,
    };
    SvdfParams {
        n: q.visibility_resolution as usize,
        clusters: q.cpca_clusters as usize,
        vectors: q.cpca_vectors as usize,
        ..base
    }
}

/// The occluder-field resolution of a quality setting.
pub fn ovdf_params(q: &QualitySettings) -> OvdfParams {
    OvdfParams {
        shells: q.ovdf_shells as usize,
        m: q.ovdf_directions as usize,
        n: q.visibility_resolution as usize,
        supersample: 2,
        vectors: q.ovdf_vectors as usize,
    }
}

/// The BRDF table resolution of a quality setting for `brdf`: its `brdf_resolution`, or
/// when that is automatic rsl-brdf's choice from the lobe width; `view_samples` views.
/// Anisotropic tables hold `V×V` views (a quarter stored), so under `auto` their `N` stays
/// at 32: at 128 one table would take 140 MB and a tenth of a second to build.
pub fn table_resolution(q: &QualitySettings, brdf: &Brdf) -> Resolution {
    let views = (q.view_samples as usize).max(2);
    match q.brdf_resolution {
        rsl_scene::quality::AUTO if brdf.is_anisotropic() => Resolution { n: 32, views },
        rsl_scene::quality::AUTO => Resolution { views, ..Resolution::auto(brdf) },
        n => Resolution { n: n as usize, views },
    }
}

/// The BRDF table resolution of [`Engine::sync_previewing`]'s preview object.
pub const PREVIEW_RESOLUTION: usize = 32;

/// Environment variable overriding [`DEFAULT_PREPARE_LIMIT`] (bytes).
pub const PREPARE_LIMIT_ENV: &str = "RSL_MAX_PREPARE_BYTES";
/// The most bytes one prepared item (a BRDF table, a visibility field's build) may take
/// unless [`PREPARE_LIMIT_ENV`] says otherwise: checked before anything is allocated, so that
/// a quality setting the file format allows (tables of 512², 512 views) is an error naming
/// its knobs rather than an exhausted machine.
pub const DEFAULT_PREPARE_LIMIT: u64 = 8 << 30;

/// The limit on one prepared item's bytes ([`DEFAULT_PREPARE_LIMIT`], or the environment's).
pub fn prepare_limit() -> Result<u64> {
    match std::env::var(PREPARE_LIMIT_ENV) {
        Err(_) => Ok(DEFAULT_PREPARE_LIMIT),
        Ok(v) => v
            .trim()
            .parse::<u64>()
            .map_err(|_| anyhow::anyhow!("{PREPARE_LIMIT_ENV} must be a whole number of bytes, got \"{v}\"")),
    }
}

/// Fails when `bytes` (what building `what` would take) is beyond [`prepare_limit`].
pub(crate) fn check_size(what: &str, knobs: &str, bytes: u64) -> Result<()> {
    let limit = prepare_limit()?;
    if bytes > limit {
        // Gigabytes where that says something, else megabytes (a low limit set for a test).
        let size = |b: u64| {
            if b >= 100_000_000 { format!("{:.1} GB", b as f64 / 1e9) } else { format!("{:.1} MB", b as f64 / 1e6) }
        };
        bail!(
            "{what} would take {} to build, more than the limit of {} ({PREPARE_LIMIT_ENV}): lower {knobs}",
            size(bytes),
            size(limit)
        );
    }
    Ok(())
}
