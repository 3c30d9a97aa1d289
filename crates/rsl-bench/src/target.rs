//! `--target-error`: the cheapest measured configuration that meets an error, written as the
//! settings a scene takes.

use crate::Row;
use crate::config::Config;
use anyhow::{Result, bail};
use rsl_scene::{Quality, QualitySettings};
use std::collections::BTreeMap;

/// The configuration picked for a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Pick {
    /// The scene, as given.
    pub scene: String,
    /// The configuration's identity.
    pub config: String,
    /// Its worst relative L2 over the bench's times.
    pub error: f64,
    /// Its median frame time over the bench's times, ms.
    pub ms_per_frame: f64,
    /// Its preparation time (the largest over the times), ms.
    pub prepare_ms: f64,
}

/// The cheapest configuration of `scene` whose relative L2 is at most `target` at every
/// time measured: least frame time first, then least preparation. An error when none is,
/// naming the most accurate one.
pub fn pick(rows: &[Row], scene: &str, target: f64) -> Result<Pick> {
    let mut by_config: BTreeMap<&str, Vec<&Row>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.scene == scene) {
        by_config.entry(&r.config).or_default().push(r);
    }
    let candidates: Vec<Pick> = by_config
        .iter()
        .map(|(config, rs)| {
            let mut ms: Vec<f64> = rs.iter().map(|r| r.ms_per_frame).collect();
            ms.sort_by(f64::total_cmp);
            Pick {
                scene: scene.to_string(),
                config: config.to_string(),
                error: rs.iter().map(|r| r.relative_l2).fold(0.0, f64::max),
                ms_per_frame: ms[ms.len() / 2],
                prepare_ms: rs.iter().map(|r| r.prepare_ms).fold(0.0, f64::max),
            }
        })
        .collect();
    if candidates.is_empty() {
        bail!("{scene}: nothing was measured");
    }
    match candidates
        .iter()
        .filter(|c| c.error <= target)
        .min_by(|a, b| a.ms_per_frame.total_cmp(&b.ms_per_frame).then(a.prepare_ms.total_cmp(&b.prepare_ms)))
    {
        Some(p) => Ok(p.clone()),
        None => {
            let best = candidates.iter().min_by(|a, b| a.error.total_cmp(&b.error)).expect("candidates");
            bail!(
                "{scene}: no configuration meets a relative L2 of {:.2}%; the most accurate, {}, reaches {:.2}%",
                100.0 * target,
                best.config,
                100.0 * best.error
            )
        }
    }
}

/// The settings of `config` as a scene fragment: a `[quality]` table holding the preset and
/// only the knobs that differ from it, and the RSL count to set in `[environment]`.
pub fn fragment(pick: &Pick, config: &Config, base: Quality, truth_spp: u32) -> Result<String> {
    let q = config.quality(base)?;
    let defaults = QualitySettings::preset(q.preset);
    let mut s = format!(
        "# rsl bench --target-error: the cheapest measured configuration of {} within the target:\n\
         # {} ({:.1} ms/frame, relative L2 {:.2}% against a {truth_spp}-spp truth).\n\
         # Use this [quality] table in the scene",
        pick.scene,
        pick.config,
        pick.ms_per_frame,
        100.0 * pick.error
    );
    match config.rsl {
        Some(n) => s += &format!(", and set rsl_count = {n} in its [environment] table.\n"),
        None => s += ".\n",
    }
    s += &format!("[quality]\npreset = \"{}\"\n", q.preset.name());
    for ((name, v), (_, d)) in q.settings.knobs().iter().zip(defaults.knobs()) {
        if *v != d {
            s += &format!("{name} = {}\n", QualitySettings::value_text(name, *v));
        }
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(config: &str, time: f32, ms: f64, prepare: f64, err: f64) -> Row {
        Row {
            scene: "s.toml".into(),
            config: config.into(),
            method: "cpu".into(),
            quality: "draft".into(),
            rsl: 30,
            time,
            prepare_ms: prepare,
            prepare_bytes: 0,
            prepare_built: 0,
            ms_per_frame: ms,
            relative_l2: err,
            mean_relative: 0.0,
            p95_relative: 0.0,
            truth_noise: 0.01,
            truth_spp: 64,
            mc_spp: None,
            mc_ms: None,
            pixel_l2: None,
            pixel_objects: Vec::new(),
            image_ms: None,
            objects: Vec::new(),
            truth_key: None,
        }
    }

    #[test]
    fn the_cheapest_configuration_meeting_the_target_at_every_time_wins() {
        let rows = [
            row("a", 0.0, 10.0, 5.0, 0.05),
            row("a", 1.0, 10.0, 5.0, 0.30), // fails at t = 1
            row("b", 0.0, 20.0, 9.0, 0.10),
            row("b", 1.0, 20.0, 9.0, 0.12),
            row("c", 0.0, 20.0, 3.0, 0.15),
            row("c", 1.0, 20.0, 3.0, 0.15),
            row("d", 0.0, 50.0, 1.0, 0.01),
            row("d", 1.0, 50.0, 1.0, 0.01),
        ];
        assert_eq!(pick(&rows, "s.toml", 0.2).unwrap().config, "c", "equal frame time: less preparation");
        assert_eq!(pick(&rows, "s.toml", 0.12).unwrap().config, "b");
        assert_eq!(pick(&rows, "s.toml", 0.3).unwrap().config, "a");
        let e = pick(&rows, "s.toml", 0.001).unwrap_err().to_string();
        assert!(e.contains("d, reaches 1.00%"), "{e}");
        assert!(pick(&rows, "other.toml", 0.5).is_err());
    }

    #[test]
    fn the_fragment_holds_the_preset_and_only_the_changed_knobs() {
        let config = crate::config::configs(&[
            "quality=paper".parse().unwrap(),
            "rsl=60".parse().unwrap(),
            "visibility_resolution=64".parse().unwrap(),
        ])
        .unwrap()
        .remove(0);
        let p = Pick { scene: "s.toml".into(), config: config.id(), error: 0.1, ms_per_frame: 30.0, prepare_ms: 1.0 };
        let f = fragment(&p, &config, Quality::default(), 256).unwrap();
        assert!(f.contains("[quality]\npreset = \"paper\"\nvisibility_resolution = 64\n"), "{f}");
        assert!(f.contains("rsl_count = 60"));
        assert_eq!(f.lines().filter(|l| !l.starts_with('#')).count(), 3, "{f}");
        // A fixed BRDF resolution over a preset's automatic one is written; "auto" reads back.
        let config = crate::config::configs(&["quality=draft".parse().unwrap(), "brdf_resolution=64".parse().unwrap()])
            .unwrap()
            .remove(0);
        let f = fragment(&p, &config, Quality::default(), 256).unwrap();
        assert!(f.contains("brdf_resolution = 64\n"), "{f}");
        let config = crate::config::configs(&["brdf_resolution=auto".parse().unwrap()]).unwrap().remove(0);
        let base = config.quality(Quality::default()).unwrap();
        assert_eq!(base.settings.brdf_resolution, rsl_scene::quality::AUTO);
    }
}
