//! Error budgets: per scene, time and configuration, the error against the truth with each
//! approximation of the RSL path replaced by its exact value (rsl-shade's oracles), one at a
//! time and all together — which term costs how much. `budget.csv` holds one row per oracle
//! (read back to resume); `report.md` shows a table per configuration.

use crate::report::{field, key_field, malformed, measure, parse_csv, read_text, truth_key};
use anyhow::Result;
use rsl_engine::output::write_atomic;
use rsl_shade::Oracles;
use std::collections::BTreeMap;
use std::path::Path;

/// The oracle settings of a budget, by name, in report order: none, each alone, all.
pub fn oracle_settings() -> Vec<(&'static str, Oracles)> {
    let mut v = vec![("none", Oracles::default())];
    v.extend(Oracles::each());
    v.push(("all", Oracles::ALL));
    v
}

/// One measured oracle setting.
#[derive(Clone, Debug, PartialEq)]
pub struct BudgetRow {
    /// The scene file as given.
    pub scene: String,
    /// The configuration's identity.
    pub config: String,
    /// Scene time, seconds.
    pub time: f32,
    /// The oracle setting's name (`none`, `light`, …, `all`).
    pub oracle: String,
    /// Relative L2 per vertex against the truth, over the scene.
    pub relative_l2: f64,
    /// The truth's own noise (relative L2 of its standard errors).
    pub truth_noise: f64,
    /// Wall time of the frame (ms), oracles included.
    pub ms: f64,
    /// Shadow rays the oracles traced.
    pub rays: u64,
    /// Per object: name and relative L2.
    pub objects: Vec<(String, f64)>,
    /// The content key of the truth it was measured against (`crate::truth::key`; `None`
    /// in files written before rows carried it, which are measured again).
    pub truth_key: Option<u64>,
}

const HEADER: &str = "scene,config,time,oracle,relative_l2,truth_noise,ms,rays,objects,truth_key";
/// The header of budget files written before rows carried their truth's key.
const HEADER_UNKEYED: &str = "scene,config,time,oracle,relative_l2,truth_noise,ms,rays,objects";

/// Writes the rows (atomically).
pub fn write_rows(path: &Path, rows: &[BudgetRow]) -> Result<()> {
    let mut s = format!("{HEADER}\n");
    for r in rows {
        let objects: Vec<String> =
            r.objects.iter().map(|(n, e)| format!("{}={e}", n.replace([';', '='], "_"))).collect();
        s += &format!(
            "{},{},{},{},{},{},{},{},{},{}\n",
            field(&r.scene),
            field(&r.config),
            r.time,
            r.oracle,
            r.relative_l2,
            r.truth_noise,
            r.ms,
            r.rays,
            field(&objects.join(";")),
            key_field(r.truth_key)
        );
    }
    write_atomic(path, s.as_bytes())
}

/// Reads `budget.csv` back (none when the file does not exist).
pub fn read_rows(path: &Path) -> Result<Vec<BudgetRow>> {
    read_text(path)?.map_or(Ok(Vec::new()), |text| parse_rows(&text, path))
}

/// The rows of a `budget.csv` text (read from `path`, which names it in messages).
pub fn parse_rows(text: &str, path: &Path) -> Result<Vec<BudgetRow>> {
    parse_csv(text, path, &[(HEADER, 10), (HEADER_UNKEYED, 9)], "budget")?
        .into_iter()
        .map(|(n, f)| {
            let bad = || malformed(path, n);
            let num = |i: usize| measure(path, n, HEADER, &f, i, false);
            let objects = f[8]
                .split(';')
                .filter(|s| !s.is_empty())
                .map(|o| {
                    let (name, e) = o.split_once('=').ok_or_else(bad)?;
                    Ok((
                        name.to_string(),
                        measure(path, n, &format!("{name} relative_l2"), &[e.to_string()], 0, false)?,
                    ))
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(BudgetRow {
                scene: f[0].clone(),
                config: f[1].clone(),
                time: measure(path, n, HEADER, &f, 2, true)? as f32,
                oracle: f[3].clone(),
                relative_l2: num(4)?,
                truth_noise: num(5)?,
                ms: num(6)?,
                rays: f[7].parse().map_err(|_| bad())?,
                objects,
                truth_key: truth_key(path, n, f.get(9))?,
            })
        })
        .collect()
}

/// The budget tables of `report.md`: per scene, time and configuration, each oracle's
/// error, how much of the plain path's error it removes, and its cost.
pub fn markdown(rows: &[BudgetRow]) -> String {
    if rows.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "\n## Error budgets\n\nEach row replaces one approximation of the RSL path by its exact value \
         (`rsl render --oracle`): `light` one RSL per environment texel instead of the fitted set; `brdf` \
         square integrals by quadrature instead of the tables; `self` and `occluders` visible fractions \
         of each square by shadow rays instead of the fields; `product` each light's whole term by \
         quadrature with a shadow ray per point (no product of averages, and no tables or fields); \
         `all` every oracle at once — what is left is the environment grid's resampling and the \
         truth's noise. \"removed\" is the share of the plain path's error (in squared relative L2, \
         which adds up for independent errors) that the oracle takes away.\n",
    );
    let mut groups: BTreeMap<(String, String, String), Vec<&BudgetRow>> = BTreeMap::new();
    for r in rows {
        groups.entry((r.scene.clone(), format!("{}", r.time), r.config.clone())).or_default().push(r);
    }
    for ((scene, time, config), rs) in groups {
        let none = rs.iter().find(|r| r.oracle == "none").map(|r| r.relative_l2);
        let noise = rs[0].truth_noise;
        let names: Vec<&str> = rs[0].objects.iter().map(|o| o.0.as_str()).collect();
        md += &format!(
            "\n### {scene} at t = {time} s, {config}\n\nTruth noise {:.2}%.\n\n| oracle | rel. L2 | removed | ms | shadow rays | {} |\n|---|---|---|---|---|{}\n",
            100.0 * noise,
            names.join(" | "),
            "---|".repeat(names.len())
        );
        let order: Vec<&str> = oracle_settings().iter().map(|o| o.0).collect();
        let mut sorted = rs.clone();
        sorted.sort_by_key(|r| order.iter().position(|o| *o == r.oracle).unwrap_or(usize::MAX));
        for r in sorted {
            let removed = match none {
                Some(n) if n > 0.0 && r.oracle != "none" => {
                    format!("{:.0}%", 100.0 * (1.0 - (r.relative_l2 * r.relative_l2) / (n * n)))
                }
                _ => "—".into(),
            };
            md += &format!(
                "| {} | {:.2}% | {} | {:.0} | {} | {} |\n",
                r.oracle,
                100.0 * r.relative_l2,
                removed,
                r.ms,
                r.rays,
                r.objects.iter().map(|o| format!("{:.2}%", 100.0 * o.1)).collect::<Vec<_>>().join(" | ")
            );
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_and_the_report_shows_what_each_oracle_removes() {
        let dir = rsl_sphere::scratch::Scratch::new("bench-budget");
        let row = |oracle: &str, e: f64| BudgetRow {
            scene: "s, \"x\".toml".into(),
            config: "method=cpu quality=paper rsl=30".into(),
            time: 0.5,
            oracle: oracle.into(),
            relative_l2: e,
            truth_noise: 0.01,
            ms: 12.0,
            rays: 7,
            objects: vec![("floor".into(), e / 2.0), ("ball".into(), e)],
            truth_key: Some(0xfedc_ba98_7654_3210),
        };
        let rows = vec![row("brdf", 0.05), row("none", 0.1), row("all", 0.01)];
        let path = dir.join("budget.csv");
        write_rows(&path, &rows).unwrap();
        assert_eq!(read_rows(&path).unwrap(), rows);
        let md = markdown(&rows);
        // 1 − 0.05²/0.1² = 75 % of the squared error removed.
        assert!(md.contains("| brdf | 5.00% | 75% |"), "{md}");
        assert!(md.find("| none |").unwrap() < md.find("| brdf |").unwrap());
        std::fs::write(&path, "x\n").unwrap();
        assert!(read_rows(&path).is_err());
    }
}
