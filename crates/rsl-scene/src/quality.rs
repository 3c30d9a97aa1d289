//! Quality presets (docs/conventions.md, Quality presets): every knob of precomputation in one place, each overridable.

use serde::Deserialize;

/// The most bounces of light the knob `bounces` takes (the truth follows each with up to a
/// ray per sample more).
pub const MAX_BOUNCES: u32 = 8;

/// Whether `aa` is a valid number of samples per pixel: a square in 1..=64 (1: the centre
/// alone, no antialiasing).
pub fn valid_aa(aa: u32) -> bool {
    let k = f64::from(aa).sqrt().round() as u32;
    (1..=64).contains(&aa) && k * k == aa
}

/// A named preset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// Fast, for tests and first looks.
    Draft,
    /// The default: the cheapest preset that meets the accuracy targets of the sun-lit,
    /// studio and overcast scenes at 30 RSLs (docs/history.md, "Accuracy against the truth"); the
    /// paper's tables and environment grid with coarse occluder-field directions.
    #[default]
    Standard,
    /// The resolutions of Xu et al. 2006.
    Paper,
    /// Finer than the paper.
    High,
}

impl Preset {
    /// All presets, in order.
    pub const ALL: [Preset; 4] = [Preset::Draft, Preset::Standard, Preset::Paper, Preset::High];

    /// Name as written in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Draft => "draft",
            Preset::Standard => "standard",
            Preset::Paper => "paper",
            Preset::High => "high",
        }
    }

    /// Parses a preset name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == s)
    }
}

/// `brdf_resolution` chosen per material from its lobe width.
pub const AUTO: u32 = 0;

/// Precomputation resolutions. Field names are the override keys of a `[quality]` table
/// (plus `table_resolution`, which sets both table resolutions at once).
///
/// BRDF tables and visibility fields have separate knobs: a BRDF table costs milliseconds,
/// a visibility field minutes, and a narrow lobe needs a fine BRDF grid whatever the
/// shadows need.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QualitySettings {
    /// `N` of the BRDF tables' `N×N` hemisphere grid; [`AUTO`] (written `"auto"`): per
    /// material from its lobe width (rsl-brdf's `Resolution::auto`), the presets' choice.
    pub brdf_resolution: u32,
    /// Polar view samples of isotropic BRDF tables (`V`; `V×V` for anisotropic ones).
    pub view_samples: u32,
    /// `N` of the `N×N` hemisphere tables of the visibility fields (self and occluder).
    pub visibility_resolution: u32,
    /// `R` of the `6×R×R` environment grid decomposed into RSLs.
    pub env_grid: u32,
    /// `M` of the `6×M×M` occluder-field directions per shell.
    pub ovdf_directions: u32,
    /// Concentric shells of the occluder field.
    pub ovdf_shells: u32,
    /// Principal vectors per occluder-field segment.
    pub ovdf_vectors: u32,
    /// Clusters of the self-visibility CPCA.
    pub cpca_clusters: u32,
    /// Principal vectors per self-visibility cluster.
    pub cpca_vectors: u32,
    /// Lights whose shadows from other objects are traced per frame instead of read from
    /// the occluder fields: the ones of highest radiance (a sun); 0 traces none.
    pub traced_lights: u32,
    /// Shadow rays per traced light per vertex (0 traces none).
    pub shadow_rays: u32,
    /// The most samples per pixel (a square: a `k×k` grid, averaged) in the pixels one
    /// sample at the centre does not resolve — silhouettes, shadow edges, small highlights:
    /// 4 in each, then `aa` (at most 16) more in those whose 4 span a wide range, and with
    /// `aa` beyond 16, `aa` more again in those whose samples still span many times the
    /// image's mean — a sun's glint (rsl-shade's `antialias`); 1 draws every pixel's centre
    /// alone (no antialiasing). Costs no precomputation.
    pub aa: u32,
    /// Lighting terms the Haar wavelet baseline (method `wavelet`) keeps per frame: the
    /// environment's largest coefficients on the `env_grid` cube (Ng et al.'s figures use
    /// 100–200). The other methods ignore it.
    pub wavelet_terms: u32,
    /// Bounces of light between surfaces: paths of up to `bounces + 1` segments, so 0 is
    /// the environment's light alone (each direction another surface blocks is black) and 1
    /// adds the light one bounce off the surfaces around. The Monte Carlo truth follows it
    /// by sampling; every other method gathers it at each vertex (`bounce_rays` directions
    /// from the vertex's BRDF, each bringing what the surface it meets sends back: that
    /// surface's own RSL shading at the point met, with the bounces before), its image
    /// adding the gathered light interpolated across triangles.
    pub bounces: u32,
    /// Directions gathered per vertex and bounce when `bounces` is above 0 (stratified over
    /// the BRDF's sampling square; a square number stratifies best). Costs no
    /// precomputation. 0 gathers nothing: the methods draw the direct light alone while the
    /// truth follows `bounces` (what the bench measures the direct light's shortfall with).
    pub bounce_rays: u32,
}

impl QualitySettings {
    /// The settings of a preset.
    pub fn preset(p: Preset) -> Self {
        match p {
            Preset::Draft => Self {
                brdf_resolution: AUTO,
                view_samples: 16,
                visibility_resolution: 16,
                env_grid: 16,
                ovdf_directions: 8,
                ovdf_shells: 8,
                ovdf_vectors: 4,
                cpca_clusters: 32,
                cpca_vectors: 4,
                traced_lights: 2,
                shadow_rays: 16,
                aa: 1,
                wavelet_terms: 200,
                bounces: 0,
                bounce_rays: 16,
            },
            Preset::Standard => Self {
                brdf_resolution: AUTO,
                view_samples: 16,
                visibility_resolution: 32,
                env_grid: 32,
                // The occluder field's cost is directions² × tables: 8 directions where the
                // paper has 32 build it 16× faster, and twice draft's shells keep thin
                // features' shadows (the other objects' shadows of the sun are traced).
                ovdf_directions: 8,
                ovdf_shells: 16,
                ovdf_vectors: 4,
                cpca_clusters: 256,
                cpca_vectors: 8,
                traced_lights: 2,
                shadow_rays: 16,
                // 36: a third round of a 6×6 grid in the pixels a glint still spans
                // (rsl-shade's `antialias::GLINT`): on the low-sun Suzanne scene 5.10 % →
                // 4.36 % per covered pixel, for about a tenth more frame time on the
                // default scene's CPU frame.
                aa: 36,
                wavelet_terms: 200,
                bounces: 0,
                bounce_rays: 64,
            },
            Preset::Paper => Self {
                brdf_resolution: AUTO,
                // 16, not the paper's 32: tables follow the lobe between views, and 32 gave
                // no measurable gain on the accuracy scenes (rsl-brdf README).
                view_samples: 16,
                visibility_resolution: 32,
                env_grid: 32,
                ovdf_directions: 32,
                ovdf_shells: 16,
                ovdf_vectors: 8,
                cpca_clusters: 256,
                cpca_vectors: 8,
                traced_lights: 2,
                shadow_rays: 16,
                aa: 64,
                wavelet_terms: 200,
                bounces: 0,
                bounce_rays: 64,
            },
            Preset::High => Self {
                brdf_resolution: AUTO,
                view_samples: 32,
                visibility_resolution: 64,
                env_grid: 64,
                ovdf_directions: 32,
                ovdf_shells: 24,
                ovdf_vectors: 16,
                cpca_clusters: 512,
                cpca_vectors: 16,
                traced_lights: 4,
                shadow_rays: 32,
                aa: 64,
                wavelet_terms: 200,
                bounces: 0,
                bounce_rays: 256,
            },
        }
    }

    /// `(name, value)` of every knob, for summaries and overrides (`brdf_resolution` is
    /// [`AUTO`] when automatic; [`QualitySettings::value_text`] writes it).
    pub fn knobs(&self) -> [(&'static str, u32); 15] {
        [
            ("brdf_resolution", self.brdf_resolution),
            ("view_samples", self.view_samples),
            ("visibility_resolution", self.visibility_resolution),
            ("env_grid", self.env_grid),
            ("ovdf_directions", self.ovdf_directions),
            ("ovdf_shells", self.ovdf_shells),
            ("ovdf_vectors", self.ovdf_vectors),
            ("cpca_clusters", self.cpca_clusters),
            ("cpca_vectors", self.cpca_vectors),
            ("traced_lights", self.traced_lights),
            ("shadow_rays", self.shadow_rays),
            ("aa", self.aa),
            ("wavelet_terms", self.wavelet_terms),
            ("bounces", self.bounces),
            ("bounce_rays", self.bounce_rays),
        ]
    }

    /// Every name [`QualitySettings::set`] accepts: the knobs and `table_resolution`.
    pub fn names() -> Vec<&'static str> {
        let mut v: Vec<&'static str> = Self::preset(Preset::Draft).knobs().iter().map(|k| k.0).collect();
        v.push("table_resolution");
        v
    }

    /// A knob's value as written in a scene file or a sweep: a whole number, or `"auto"`
    /// for `brdf_resolution` and `table_resolution` ([`AUTO`]).
    pub fn parse_value(name: &str, text: &str) -> Result<i64, String> {
        let t = text.trim();
        if t == "auto" {
            return match name {
                "brdf_resolution" => Ok(i64::from(AUTO)),
                _ => Err(format!("`auto` is only for brdf_resolution, not {name}")),
            };
        }
        let n: i64 = t.parse().map_err(|_| format!("`{t}` is not a whole number"))?;
        if name == "brdf_resolution" && n == i64::from(AUTO) {
            // 0 stands for "auto" inside rsl; written, it is out of range.
            return Err(format!("must be in 2..=512 or \"auto\", got {n}"));
        }
        Ok(n)
    }

    /// A knob's value as a scene file writes it (`"auto"` for an automatic BRDF resolution).
    pub fn value_text(name: &str, value: u32) -> String {
        if name == "brdf_resolution" && value == AUTO { "\"auto\"".into() } else { value.to_string() }
    }

    /// Sets one knob by name; errors name the knob and the allowed range. `table_resolution`
    /// sets `brdf_resolution` and `visibility_resolution` together.
    pub fn set(&mut self, name: &str, value: i64) -> Result<(), String> {
        if name == "brdf_resolution" && value == i64::from(AUTO) {
            self.brdf_resolution = AUTO;
            return Ok(());
        }
        let (lo, hi) = match name {
            "table_resolution" | "brdf_resolution" | "visibility_resolution" | "env_grid" | "ovdf_directions" => {
                (2, 512)
            }
            "view_samples" => (1, 512),
            "ovdf_shells" => (2, 256),
            "ovdf_vectors" | "cpca_vectors" => (1, 256),
            "cpca_clusters" => (1, 65_536),
            "traced_lights" => (0, 64),
            "shadow_rays" => (0, 4096),
            "wavelet_terms" => (1, 6 * 512 * 512),
            "bounces" => (0, i64::from(MAX_BOUNCES)),
            "bounce_rays" => (0, 4096),
            "aa" => {
                if !u32::try_from(value).is_ok_and(valid_aa) {
                    return Err(format!(
                        "must be a square number of samples per pixel (1, 4, 9, 16, 25, 36, 49 or 64), got {value}"
                    ));
                }
                (1, 64)
            }
            _ => {
                return Err(format!("unknown quality setting `{name}`; known: {}", Self::names().join(", ")));
            }
        };
        if !(lo..=hi).contains(&value) {
            let auto = if name == "brdf_resolution" { " or \"auto\"" } else { "" };
            return Err(format!("must be in {lo}..={hi}{auto}, got {value}"));
        }
        let v = value as u32;
        match name {
            "table_resolution" => {
                self.brdf_resolution = v;
                self.visibility_resolution = v;
            }
            "brdf_resolution" => self.brdf_resolution = v,
            "visibility_resolution" => self.visibility_resolution = v,
            "view_samples" => self.view_samples = v,
            "env_grid" => self.env_grid = v,
            "ovdf_directions" => self.ovdf_directions = v,
            "ovdf_shells" => self.ovdf_shells = v,
            "ovdf_vectors" => self.ovdf_vectors = v,
            "cpca_clusters" => self.cpca_clusters = v,
            "traced_lights" => self.traced_lights = v,
            "shadow_rays" => self.shadow_rays = v,
            "aa" => self.aa = v,
            "wavelet_terms" => self.wavelet_terms = v,
            "bounces" => self.bounces = v,
            "bounce_rays" => self.bounce_rays = v,
            _ => self.cpca_vectors = v,
        }
        Ok(())
    }
}

/// A preset plus the knobs the user overrode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quality {
    /// The preset the settings started from.
    pub preset: Preset,
    /// The effective settings.
    pub settings: QualitySettings,
}

impl Default for Quality {
    fn default() -> Self {
        Self::from_preset(Preset::default())
    }
}

impl Quality {
    /// A preset without overrides.
    pub fn from_preset(preset: Preset) -> Self {
        Self { preset, settings: QualitySettings::preset(preset) }
    }
}
