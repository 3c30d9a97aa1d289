//! Configurations: what one measured point of the study is, and the sweeps that make them.

use anyhow::{Result, bail};
use rsl_engine::{Device, MethodId};
use rsl_scene::{Preset, Quality, QualitySettings};

/// One configuration: a method, a quality (the scene's, or a preset) with knob overrides,
/// and an RSL count (the scene's, or swept).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Config {
    /// The method measured (the registry's).
    pub method: MethodId,
    /// Where it runs (the CPU unless swept).
    pub device: Device,
    /// The preset the settings start from (`None`: the scene's own quality, overrides and
    /// all).
    pub quality: Option<Preset>,
    /// Number of RSLs (`None`: the scene's).
    pub rsl: Option<u32>,
    /// Knobs set over the quality, in sweep order.
    pub knobs: Vec<(String, i64)>,
}

impl Config {
    /// A stable, readable identity: `method=cpu quality=draft rsl=30 table_resolution=64`
    /// (what is not swept is left out).
    pub fn id(&self) -> String {
        let mut s = format!("method={}", self.method_name());
        if let Some(q) = self.quality {
            s.push_str(&format!(" quality={}", q.name()));
        }
        if let Some(n) = self.rsl {
            s.push_str(&format!(" rsl={n}"));
        }
        for (k, v) in &self.knobs {
            s.push_str(&format!(" {k}={v}"));
        }
        s
    }

    /// The method's name in identities and reports: its name, or the alias that names it on
    /// this device (`cpu` and `gpu` for the RSL path), with the device where that is not the
    /// CPU and no alias names it.
    pub fn method_name(&self) -> String {
        let alias = self.method.name_on(self.device);
        if alias != self.method.name() || self.device == Device::Cpu {
            alias.to_string()
        } else {
            format!("{}@{}", self.method, self.device)
        }
    }

    /// The quality the configuration asks for, over the scene's `base`.
    pub fn quality(&self, base: Quality) -> Result<Quality> {
        let mut q = match self.quality {
            Some(p) => Quality::from_preset(p),
            None => base,
        };
        for (k, v) in &self.knobs {
            q.settings.set(k, *v).map_err(|e| anyhow::anyhow!("--sweep {k}={v}: {e}"))?;
        }
        Ok(q)
    }
}

/// One `--sweep KEY=V1,V2,…`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sweep {
    /// `rsl`, `quality`, `method`, `device`, or a quality knob (`table_resolution`, …).
    pub key: String,
    /// The values, as written.
    pub values: Vec<String>,
}

impl std::str::FromStr for Sweep {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (key, values) = s.split_once('=').ok_or_else(|| format!("expected KEY=V1,V2,… got `{s}`"))?;
        let key = key.trim().to_string();
        let values: Vec<String> = values.split(',').map(|v| v.trim().to_string()).filter(|v| !v.is_empty()).collect();
        if values.is_empty() {
            return Err(format!("--sweep {key}: no values"));
        }
        let knobs = QualitySettings::names();
        if !["rsl", "quality", "method", "device"].contains(&key.as_str()) && !knobs.contains(&key.as_str()) {
            return Err(format!("--sweep {key}: unknown; known: rsl, quality, method, device, {}", knobs.join(", ")));
        }
        Ok(Sweep { key, values })
    }
}

/// The sweep a bench runs when given none: 10–300 RSLs at the draft and paper presets.
pub fn default_sweeps() -> Vec<Sweep> {
    vec![
        "rsl=10,30,60,100,300".parse().expect("valid default sweep"),
        "quality=draft,paper".parse().expect("valid default sweep"),
    ]
}

/// Most configurations one bench may hold (the product of its sweeps).
pub const MAX_CONFIGS: usize = 10_000;

/// Every combination of the sweeps (the last sweep varies fastest), each checked: unknown
/// values, RSL counts of 0 and knobs out of range are errors that name the sweep.
pub fn configs(sweeps: &[Sweep]) -> Result<Vec<Config>> {
    for (k, s) in sweeps.iter().enumerate() {
        if let Some(first) = sweeps[..k].iter().find(|t| t.key == s.key) {
            bail!(
                "--sweep {key} is given twice ({key}={} and {key}={}): give all its values in one, --sweep {key}={},{}",
                first.values.join(","),
                s.values.join(","),
                first.values.join(","),
                s.values.join(","),
                key = s.key
            );
        }
        if let Some((i, v)) = s.values.iter().enumerate().find(|(i, v)| s.values[..*i].contains(v)) {
            bail!("--sweep {}: `{v}` is listed twice (value {} of {})", s.key, i + 1, s.values.len());
        }
    }
    let count = sweeps.iter().try_fold(1usize, |n, s| n.checked_mul(s.values.len()));
    match count {
        Some(n) if n <= MAX_CONFIGS => {}
        _ => bail!("the sweeps make more than {MAX_CONFIGS} configurations"),
    }
    let mut out =
        vec![Config { method: MethodId::RSL, device: Device::Cpu, quality: None, rsl: None, knobs: Vec::new() }];
    for s in sweeps {
        let mut next = Vec::with_capacity(out.len() * s.values.len());
        for c in &out {
            for v in &s.values {
                let mut c = c.clone();
                match s.key.as_str() {
                    "rsl" => {
                        c.rsl =
                            Some(v.parse().ok().filter(|&n: &u32| n > 0).ok_or_else(|| {
                                anyhow::anyhow!("--sweep rsl: `{v}` is not a positive number of lights")
                            })?);
                    }
                    "quality" => {
                        c.quality = Some(Preset::from_name(v).ok_or_else(|| {
                            anyhow::anyhow!("--sweep quality: `{v}` is not a preset (draft, standard, paper, high)")
                        })?);
                    }
                    "method" => {
                        let (m, device) = MethodId::parse_with_device(v)
                            .map_err(|e| anyhow::anyhow!("--sweep method: `{v}` is not a method ({e})"))?;
                        c.method = m;
                        if let Some(d) = device {
                            c.device = d;
                        }
                    }
                    "device" => {
                        c.device = v.parse().map_err(|e| anyhow::anyhow!("--sweep device: {e}"))?;
                    }
                    knob => {
                        let n = QualitySettings::parse_value(knob, v)
                            .map_err(|e| anyhow::anyhow!("--sweep {knob}: {e}"))?;
                        c.knobs.retain(|(k, _)| k != knob);
                        c.knobs.push((knob.to_string(), n));
                    }
                }
                c.quality(Quality::default())?;
                next.push(c);
            }
        }
        out = next;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweeps_multiply_and_name_their_configurations() {
        let sweeps: Vec<Sweep> =
            ["rsl=10,30", "quality=draft,paper", "table_resolution=16"].iter().map(|s| s.parse().unwrap()).collect();
        let c = configs(&sweeps).unwrap();
        assert_eq!(c.len(), 4);
        assert_eq!(c[0].id(), "method=cpu quality=draft rsl=10 table_resolution=16");
        assert_eq!(c[3].id(), "method=cpu quality=paper rsl=30 table_resolution=16");
        let q = c[3].quality(Quality::default()).unwrap().settings;
        assert_eq!((q.brdf_resolution, q.visibility_resolution), (16, 16), "table_resolution sets both");
        let scene_own = configs(&["method=cpu,gpu".parse().unwrap()]).unwrap();
        assert_eq!(scene_own[1].id(), "method=gpu");
        let base = Quality::from_preset(Preset::High);
        assert_eq!(scene_own[1].quality(base).unwrap(), base, "unswept quality is the scene's");
    }

    #[test]
    fn bad_sweeps_are_clear_errors() {
        assert!("rsl".parse::<Sweep>().unwrap_err().contains("KEY=V1"));
        assert!("colour=1".parse::<Sweep>().unwrap_err().contains("known: rsl"));
        let err = |s: &str| format!("{:#}", configs(&[s.parse().unwrap()]).unwrap_err());
        assert!(err("rsl=0").contains("positive"));
        assert!(err("rsl=5,10,5").contains("`5` is listed twice"));
        let twice: Vec<Sweep> = ["rsl=5,10", "quality=draft", "rsl=7"].iter().map(|s| s.parse().unwrap()).collect();
        let e = format!("{:#}", configs(&twice).unwrap_err());
        assert!(e.contains("--sweep rsl is given twice") && e.contains("--sweep rsl=5,10,7"), "{e}");
        assert!(err("quality=ultra").contains("preset"));
        assert!(err("method=tpu").contains("method"));
        assert!(err("table_resolution=4096").contains("table_resolution"));
    }
}
