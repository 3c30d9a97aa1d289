//! The bench's files: `results.csv` (one row per scene, configuration and time; read back to
//! resume), `objects.csv` (per object), `report.md`, and per scene three SVG plots.

use crate::Row;
use crate::plot::{Plot, Series, pareto};
use anyhow::{Result, bail};
use rsl_engine::output::write_atomic;
use std::collections::BTreeMap;
use std::path::Path;

const HEADER: &str = "scene,config,method,quality,rsl,time,prepare_ms,prepare_bytes,prepare_built,ms_per_frame,relative_l2,\
                      mean_relative,p95_relative,truth_noise,truth_spp,mc_spp,mc_ms,pixel_l2,pixel_truth_noise,objects,\
                      truth_key,pixel_objects,image_ms";

/// The header of results written before rows carried their image's frame time: read, with
/// none (the image pass measures it again).
const HEADER_NO_IMAGE_MS: &str = "scene,config,method,quality,rsl,time,prepare_ms,prepare_bytes,prepare_built,\
                                  ms_per_frame,relative_l2,mean_relative,p95_relative,truth_noise,truth_spp,mc_spp,\
                                  mc_ms,pixel_l2,pixel_truth_noise,objects,truth_key,pixel_objects";

/// The header of results written before rows carried their per-object pixel errors: read,
/// with none (the image pass fills them in again).
const HEADER_NO_PIXEL_OBJECTS: &str = "scene,config,method,quality,rsl,time,prepare_ms,prepare_bytes,prepare_built,\
                                       ms_per_frame,relative_l2,mean_relative,p95_relative,truth_noise,truth_spp,mc_spp,\
                                       mc_ms,pixel_l2,pixel_truth_noise,objects,truth_key";

/// The header of results written before rows carried their truth's key: read, and every
/// row measured again.
const HEADER_UNKEYED: &str = "scene,config,method,quality,rsl,time,prepare_ms,prepare_bytes,prepare_built,ms_per_frame,\
                              relative_l2,mean_relative,p95_relative,truth_noise,truth_spp,mc_spp,mc_ms,pixel_l2,\
                              pixel_truth_noise,objects";

/// A CSV field, quoted when it holds a comma, a quote or a line break.
pub(crate) fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

/// The fields of one CSV line (quotes doubled inside quoted fields).
pub(crate) fn split(line: &str) -> Vec<String> {
    let (mut out, mut cur, mut quoted, mut chars) = (Vec::new(), String::new(), false, line.chars().peekable());
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// Per object `name=relative_l2/noise`, joined by `;` (a field of its own).
fn objects_field(objects: &[(String, f64, f64)]) -> String {
    objects.iter().map(|(n, e, s)| format!("{}={e}/{s}", n.replace([';', '=', '/'], "_"))).collect::<Vec<_>>().join(";")
}

/// Writes the rows (atomically) as `results.csv` (or a shard's results file), and `objects.csv`
/// (or the shard's) beside it.
pub fn write_rows(path: &Path, rows: &[Row]) -> Result<()> {
    let mut s = format!("{HEADER}\n");
    let mut o = String::from("scene,config,time,object,relative_l2,truth_noise,pixel_relative_l2,pixel_truth_noise\n");
    for r in rows {
        s += &format!(
            // Floats in their shortest exact form, so a resumed bench reads back what it wrote.
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            field(&r.scene),
            field(&r.config),
            r.method,
            r.quality,
            r.rsl,
            r.time,
            r.prepare_ms,
            r.prepare_bytes,
            r.prepare_built,
            r.ms_per_frame,
            r.relative_l2,
            r.mean_relative,
            r.p95_relative,
            r.truth_noise,
            r.truth_spp,
            r.mc_spp.map_or(String::new(), |v| v.to_string()),
            r.mc_ms.map_or(String::new(), |v| v.to_string()),
            r.pixel_l2.map_or(String::new(), |v| v.0.to_string()),
            r.pixel_l2.map_or(String::new(), |v| v.1.to_string()),
            field(&objects_field(&r.objects)),
            key_field(r.truth_key),
            field(&objects_field(&r.pixel_objects)),
            r.image_ms.map_or(String::new(), |v| v.to_string())
        );
        for (name, e, n) in &r.objects {
            let pixel =
                r.pixel_objects.iter().find(|p| p.0 == *name).map_or(",".into(), |p| format!("{},{}", p.1, p.2));
            o += &format!("{},{},{},{},{e},{n},{pixel}\n", field(&r.scene), field(&r.config), r.time, field(name));
        }
    }
    write_atomic(path, s.as_bytes())?;
    write_atomic(&objects_path(path), o.as_bytes())
}

/// The per-object file written beside results file `path`: `objects.csv` beside
/// `results.csv`, a shard's `objects-shard-K-of-N.csv` beside its `results-shard-K-of-N.csv`.
pub fn objects_path(path: &Path) -> std::path::PathBuf {
    let name = path.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
    match name.replacen("results", "objects", 1) {
        o if o == name => path.with_file_name("objects.csv"),
        o => path.with_file_name(o),
    }
}

/// The text of a file of the bench's (none when it does not exist), at most
/// [`rsl_sphere::io::MAX_DATA_BYTES`].
pub(crate) fn read_text(path: &Path) -> Result<Option<String>> {
    use rsl_sphere::io::{MAX_DATA_BYTES, ReadError, read_text_bounded};
    match read_text_bounded(path, MAX_DATA_BYTES) {
        Ok(t) => Ok(Some(t)),
        Err(ReadError::NotFound) => Ok(None),
        Err(e) => Err(anyhow::anyhow!("cannot read {}: {e}", path.display())),
    }
}

/// The fields of every line but the header of a CSV text (from `path`, for messages) whose
/// header is one of `headers` (each with its field count), with their line numbers; `kind`
/// names the file in the error for another header, and a line with other than its header's
/// field count is malformed.
pub(crate) fn parse_csv(
    text: &str,
    path: &Path,
    headers: &[(&str, usize)],
    kind: &str,
) -> Result<Vec<(usize, Vec<String>)>> {
    let mut lines = text.lines();
    let first = lines.next();
    let Some(&(_, fields)) = headers.iter().find(|(h, _)| first == Some(*h)) else {
        bail!("{}: not a {kind} file of this version (header differs); move it away to start afresh", path.display());
    };
    lines
        .enumerate()
        .map(|(k, line)| {
            let f = split(line);
            if f.len() != fields {
                return Err(malformed(path, k + 2));
            }
            Ok((k + 2, f))
        })
        .collect()
}

/// The `truth_key` field of line `n` of `path` (`None` when the file has no such column or
/// the row no key).
pub(crate) fn truth_key(path: &Path, n: usize, field: Option<&String>) -> Result<Option<u64>> {
    match field.map(String::as_str) {
        None | Some("") => Ok(None),
        Some(k) => u64::from_str_radix(k, 16)
            .map(Some)
            .map_err(|_| anyhow::anyhow!("{}: line {n}: truth_key `{k}` is not a key rsl writes", path.display())),
    }
}

/// A truth key as the CSV files write it.
pub(crate) fn key_field(key: Option<u64>) -> String {
    key.map_or(String::new(), |k| format!("{k:016x}"))
}

/// The error for line `n` of `path`.
pub(crate) fn malformed(path: &Path, n: usize) -> anyhow::Error {
    anyhow::anyhow!("{}: line {n}: malformed row", path.display())
}

/// Field `i` of a row read from line `n` of `path` (its columns named by `header`) as a
/// measure: a finite number, ≥ 0 unless `signed`. A saved row holding NaN, an infinity or a
/// negative time is refused by name (one panicked the report, and others ranked first).
pub(crate) fn measure(path: &Path, n: usize, header: &str, f: &[String], i: usize, signed: bool) -> Result<f64> {
    let name = header.split(',').nth(i).unwrap_or("a field");
    let v: f64 =
        f[i].parse().map_err(|_| anyhow::anyhow!("{}: line {n}: {name} `{}` is not a number", path.display(), f[i]))?;
    if !(v.is_finite() && (signed || v >= 0.0)) {
        bail!(
            "{}: line {n}: {name} is {v}, not a measure rsl writes (finite{}); move the file away to measure afresh",
            path.display(),
            if signed { "" } else { ", ≥ 0" }
        );
    }
    Ok(v)
}

/// Reads `results.csv` back (none when the file does not exist).
pub fn read_rows(path: &Path) -> Result<Vec<Row>> {
    read_text(path)?.map_or(Ok(Vec::new()), |text| parse_rows(&text, path))
}

/// The rows of a `results.csv` text (read from `path`, which names it in messages).
pub fn parse_rows(text: &str, path: &Path) -> Result<Vec<Row>> {
    let headers = [(HEADER, 23), (HEADER_NO_IMAGE_MS, 22), (HEADER_NO_PIXEL_OBJECTS, 21), (HEADER_UNKEYED, 20)];
    parse_csv(text, path, &headers, "results")?
        .into_iter()
        .map(|(n, f)| {
            let bad = || malformed(path, n);
            let num = |i: usize| measure(path, n, HEADER, &f, i, false);
            let objects_in = |field: &str| {
                field
                    .split(';')
                    .filter(|s| !s.is_empty())
                    .map(|o| {
                        let (name, rest) = o.split_once('=').ok_or_else(bad)?;
                        let (e, s) = rest.split_once('/').ok_or_else(bad)?;
                        let pair = [e.to_string(), s.to_string()];
                        let header = format!("{name} relative_l2,{name} truth_noise");
                        Ok((
                            name.to_string(),
                            measure(path, n, &header, &pair, 0, false)?,
                            measure(path, n, &header, &pair, 1, false)?,
                        ))
                    })
                    .collect::<Result<Vec<_>>>()
            };
            let objects = objects_in(&f[19])?;
            let pixel_objects = objects_in(f.get(21).map_or("", String::as_str))?;
            Ok(Row {
                scene: f[0].clone(),
                config: f[1].clone(),
                method: f[2].clone(),
                quality: f[3].clone(),
                rsl: f[4].parse().map_err(|_| bad())?,
                time: measure(path, n, HEADER, &f, 5, true)? as f32,
                prepare_ms: num(6)?,
                prepare_bytes: f[7].parse().map_err(|_| bad())?,
                prepare_built: f[8].parse().map_err(|_| bad())?,
                ms_per_frame: num(9)?,
                relative_l2: num(10)?,
                mean_relative: num(11)?,
                p95_relative: num(12)?,
                truth_noise: num(13)?,
                truth_spp: f[14].parse().map_err(|_| bad())?,
                mc_spp: if f[15].is_empty() { None } else { Some(num(15)?) },
                mc_ms: if f[16].is_empty() { None } else { Some(num(16)?) },
                pixel_l2: if f[17].is_empty() { None } else { Some((num(17)?, num(18)?)) },
                objects,
                pixel_objects,
                image_ms: match f.get(22) {
                    Some(v) if !v.is_empty() => Some(num(22)?),
                    _ => None,
                },
                truth_key: truth_key(path, n, f.get(20))?,
            })
        })
        .collect()
}

/// A speed-up in two significant figures: `0.39×`, `3.0×`, `120×`.
fn speedup(x: f64) -> String {
    if x < 10.0 { format!("{x:.2}×") } else { format!("{x:.0}×") }
}

/// A file-name-safe stem of a scene path.
pub fn stem(scene: &str) -> String {
    let s = Path::new(scene).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect()
}

/// The configuration without its RSL count: the series a sweep of counts draws as one line.
fn series_of(config: &str) -> String {
    config.split(' ').filter(|p| !p.starts_with("rsl=")).collect::<Vec<_>>().join(" ")
}

/// A relative L2 `error` against a truth of relative noise `noise`, the noise taken out:
/// `√(e² − σ²)` (the truth's noise adds σ² to the expected squared error), or "within noise"
/// where the error is no larger than the noise.
pub fn less_noise(error: f64, noise: f64) -> String {
    let left = error * error - noise * noise;
    if left > 0.0 { format!("{:.2}%", 100.0 * left.sqrt()) } else { "within noise".into() }
}

/// A relative L2 `error` with the truth's `noise` beside it, flagged where it is within
/// that noise (the truth cannot tell it from zero).
pub fn with_noise(error: f64, noise: f64) -> String {
    let within = if error <= noise { ", within noise" } else { "" };
    format!("{:.2}% ({:.2}%{within})", 100.0 * error, 100.0 * noise)
}

/// Writes `report.md` (headed by `command`, the command that produced it, when not empty)
/// and the plots of every scene into `out`; the per-pixel figures were measured at the
/// camera's resolution with `grid_full`, else at half of it.
pub fn write_reports(
    out: &Path,
    command: &str,
    rows: &[Row],
    budget: &[crate::budget::BudgetRow],
    grid_full: bool,
) -> Result<()> {
    let (md, plots) = reports(command, rows, budget, grid_full, &|grid| out.join(grid).exists());
    for (file, plot) in plots {
        write_atomic(&out.join(format!("{file}.svg")), plot.svg().as_bytes())?;
        let (rgb, w, h) = plot.rgb();
        rsl_engine::output::write_png(&out.join(format!("{file}.png")), w, h, rgb)?;
    }
    write_atomic(&out.join("report.md"), md.as_bytes())
}

/// What [`write_reports`] writes: the text of `report.md`, and the plots by file stem (each
/// written as SVG and PNG); `grid_exists` says whether a grid image of that name is in the
/// output folder (the report links it).
pub fn reports(
    command: &str,
    rows: &[Row],
    budget: &[crate::budget::BudgetRow],
    grid_full: bool,
    grid_exists: &dyn Fn(&str) -> bool,
) -> (String, Vec<(String, Plot)>) {
    let mut files = Vec::new();
    let mut by_scene: BTreeMap<&str, Vec<&Row>> = BTreeMap::new();
    for r in rows {
        by_scene.entry(&r.scene).or_default().push(r);
    }
    let mut md = String::from(
        "# rsl bench\n\nPer scene and time: every configuration's preparation (wall ms from an empty memory \
         store, bytes held), shading time per frame (median; the vertices' shading, with the \
         interreflections gathered at them where `bounces` asks; the whole frame with its image, drawn per \
         pixel where the method draws so, is the per-pixel table's ms/image), and error per vertex against the Monte Carlo \
         truth — relative L2 over the scene and per object, mean and 95th percentile of the per-vertex \
         relative error — with the truth's own noise (relative L2 of its standard errors). ★ marks the \
         Pareto front (no configuration is both faster and more accurate). Preparation is wall time \
         with the disk cache: \"built\" counts the items (light sets, tables, fields) built for the \
         configuration rather than read; the first configuration of a quality pays for its fields. \
         The per-vertex relative errors leave out vertices darker than 1% of the mean (they weigh \
         in the relative L2). \"MC spp at equal error\" is how many samples per vertex the Monte Carlo \
         estimator needs to be as far from the truth, from the truth's measured noise and the 1/√samples \
         law; \"× faster\" compares that estimate's time on this machine (its samples only, not the \
         rebuilding of its ray-tracing structures per frame) with the frame time; below 1× Monte \
         Carlo is faster at equal error. \"less noise\" is the error with the truth's own noise taken \
         out, √(e² − σ²): the truth's noise σ adds σ² to the expected squared error; \"within \
         noise\" where the error is no larger than the noise.\n",
    );
    if !command.is_empty() {
        md.insert_str("# rsl bench\n\n".len(), &format!("Written by:\n\n```sh\n{command}\n```\n\n"));
    }
    for (scene, rows) in &by_scene {
        let stem = stem(scene);
        let mut times: Vec<f32> = rows.iter().map(|r| r.time).collect();
        times.sort_by(f32::total_cmp);
        times.dedup();
        for t in &times {
            let mut rs: Vec<&&Row> = rows.iter().filter(|r| r.time == *t).collect();
            rs.sort_by(|a, b| a.ms_per_frame.total_cmp(&b.ms_per_frame));
            let pts: Vec<(f64, f64)> = rs.iter().map(|r| (r.ms_per_frame, r.relative_l2)).collect();
            let front = pareto(&pts);
            let first = rs[0];
            md += &format!(
                "\n## {scene} at t = {t} s\n\nTruth: {} samples per vertex, its own noise {:.2}% ({}).\n\n",
                first.truth_spp,
                100.0 * first.truth_noise,
                first.objects.iter().map(|(n, _, s)| format!("{n} {:.2}%", 100.0 * s)).collect::<Vec<_>>().join(", ")
            );
            let names: Vec<&str> = first.objects.iter().map(|o| o.0.as_str()).collect();
            md += &format!(
                "| configuration | ms/frame | prepare ms | built | MB | rel. L2 | less noise | mean rel. | p95 rel. | pixel rel. L2 | MC spp at equal error | × faster than MC | {} |\n|---|---|---|---|---|---|---|---|---|---|---|---|{}\n",
                names.join(" | "),
                "---|".repeat(names.len())
            );
            for (k, r) in rs.iter().enumerate() {
                md += &format!(
                    "| {}{} | {:.1} | {:.0} | {} | {:.1} | {:.2}% | {} | {:.2}% | {:.2}% | {} | {} | {} | {} |\n",
                    if front.contains(&k) { "★ " } else { "" },
                    r.config,
                    r.ms_per_frame,
                    r.prepare_ms,
                    r.prepare_built,
                    r.prepare_bytes as f64 / 1e6,
                    100.0 * r.relative_l2,
                    less_noise(r.relative_l2, r.truth_noise),
                    100.0 * r.mean_relative,
                    100.0 * r.p95_relative,
                    r.pixel_l2.map_or_else(
                        || "—".into(),
                        |(e, n)| format!(
                            "{:.2}% (truth noise {:.2}%; less noise {})",
                            100.0 * e,
                            100.0 * n,
                            less_noise(e, n)
                        )
                    ),
                    r.mc_spp.map_or_else(|| "— (within the truth's noise)".into(), |s| format!("{s:.1}")),
                    r.mc_ms.map_or_else(|| "—".into(), |m| speedup(m / r.ms_per_frame)),
                    r.objects.iter().map(|o| format!("{:.2}%", 100.0 * o.1)).collect::<Vec<_>>().join(" | ")
                );
            }
            let resolution = if grid_full { "the camera's resolution" } else { "half the camera's resolution" };
            let pixel_names: Vec<&str> =
                rs.iter().flat_map(|r| r.pixel_objects.iter().map(|o| o.0.as_str())).fold(Vec::new(), |mut v, n| {
                    if !v.contains(&n) {
                        v.push(n);
                    }
                    v
                });
            if !pixel_names.is_empty() {
                md += &format!(
                    "\nPer covered pixel, at {resolution}, against the per-pixel truth (each figure with the truth's own \
                     noise over the same pixels, flagged where it is within that noise; an object's pixels are \
                     those whose centre sees it; ms/image is the whole frame with its image at that \
                     resolution, the median of the frames timed):\n\n\
                     | configuration | ms/image | all pixels | {} |\n|---|---|---|{}\n",
                    pixel_names.join(" | "),
                    "---|".repeat(pixel_names.len())
                );
                for r in rs.iter().filter(|r| r.pixel_l2.is_some()) {
                    let (e, n) = r.pixel_l2.unwrap_or_default();
                    let cells: Vec<String> = pixel_names
                        .iter()
                        .map(|name| {
                            r.pixel_objects
                                .iter()
                                .find(|o| o.0 == *name)
                                .map_or_else(|| "—".into(), |o| with_noise(o.1, o.2))
                        })
                        .collect();
                    md += &format!(
                        "| {} | {} | {:.2}% ({:.2}%; less noise {}) | {} |\n",
                        r.config,
                        r.image_ms.map_or_else(|| "—".into(), |ms| format!("{ms:.1}")),
                        100.0 * e,
                        100.0 * n,
                        less_noise(e, n),
                        cells.join(" | ")
                    );
                }
            }
            let grid = format!("{stem}_grid_t{t}.png");
            if grid_exists(&grid) {
                md += &format!(
                    "\nThe grid (at {resolution}; first row the per-pixel truth, then per configuration its render \
                     and its luminance error, one colour scale for all): ![grid]({grid})\n"
                );
            }
        }
        let noise = rows.iter().map(|r| r.truth_noise).fold(0.0, f64::max);
        let reference = vec![(100.0 * noise, format!("truth noise {:.2}%", 100.0 * noise))];
        // Error against frame time, with the front.
        let pts: Vec<(f64, f64)> = rows.iter().map(|r| (r.ms_per_frame, 100.0 * r.relative_l2)).collect();
        let front: Vec<(f64, f64)> = pareto(&pts).into_iter().map(|i| pts[i]).collect();
        let mut series =
            group(rows, |r| format!("{} {}", r.method, r.quality), |r| (r.ms_per_frame, 100.0 * r.relative_l2), false);
        series.push(Series { name: "Pareto front".into(), points: front, line: true });
        let with_rsls: Vec<&Row> = rows.iter().copied().filter(|r| r.rsl > 0).collect();
        let mut plots = vec![
            (
                "error_vs_ms",
                Plot {
                    title: format!("{scene}: error against frame time"),
                    x_label: "shading time per frame (ms, median)".into(),
                    y_label: "relative L2 against the truth (%)".into(),
                    x_log: true,
                    y_log: true,
                    series,
                    references: reference.clone(),
                },
            ),
            (
                "error_vs_rsl",
                Plot {
                    title: format!("{scene}: error against RSL count"),
                    x_label: "RSLs".into(),
                    y_label: "relative L2 against the truth (%)".into(),
                    x_log: true,
                    y_log: true,
                    // Methods without square lights (the wavelet baseline) are not on it.
                    series: group(
                        &with_rsls,
                        |r| series_of(&r.config),
                        |r| (f64::from(r.rsl), 100.0 * r.relative_l2),
                        true,
                    ),
                    references: reference.clone(),
                },
            ),
            (
                "precompute_vs_error",
                Plot {
                    title: format!("{scene}: preparation against error"),
                    x_label: "preparation (ms)".into(),
                    y_label: "relative L2 against the truth (%)".into(),
                    x_log: true,
                    y_log: true,
                    series: group(
                        rows,
                        |r| format!("{} {}", r.method, r.quality),
                        |r| (r.prepare_ms.max(0.01), 100.0 * r.relative_l2),
                        false,
                    ),
                    references: reference,
                },
            ),
        ];
        // The image's error against the image's frame time, where the images were timed.
        let imaged: Vec<&Row> = rows.iter().copied().filter(|r| r.image_ms.is_some() && r.pixel_l2.is_some()).collect();
        if !imaged.is_empty() {
            let point = |r: &Row| (r.image_ms.unwrap_or_default().max(0.01), 100.0 * r.pixel_l2.unwrap_or_default().0);
            let pts: Vec<(f64, f64)> = imaged.iter().map(|r| point(r)).collect();
            let front: Vec<(f64, f64)> = pareto(&pts).into_iter().map(|i| pts[i]).collect();
            let mut series = group(&imaged, |r| format!("{} {}", r.method, r.quality), point, false);
            series.push(Series { name: "Pareto front".into(), points: front, line: true });
            let noise = imaged.iter().map(|r| r.pixel_l2.unwrap_or_default().1).fold(0.0, f64::max);
            plots.push((
                "pixel_error_vs_ms",
                Plot {
                    title: format!("{scene}: image error against frame time"),
                    x_label: "frame with its image (ms, median)".into(),
                    y_label: "relative L2 per covered pixel against the truth (%)".into(),
                    x_log: true,
                    y_log: true,
                    series,
                    references: vec![(100.0 * noise, format!("truth noise {:.2}%", 100.0 * noise))],
                },
            ));
        }
        md += "\n";
        for (name, plot) in plots {
            md += &format!("![{}]({stem}_{name}.svg)\n", plot.title);
            files.push((format!("{stem}_{name}"), plot));
        }
    }
    md += &crate::budget::markdown(budget);
    (md, files)
}

/// The rows grouped into series by `key`, points by `point` (sorted by x).
fn group(rows: &[&Row], key: impl Fn(&Row) -> String, point: impl Fn(&Row) -> (f64, f64), line: bool) -> Vec<Series> {
    let mut m: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for r in rows {
        m.entry(key(r)).or_default().push(point(r));
    }
    m.into_iter()
        .map(|(name, mut points)| {
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series { name, points, line }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(config: &str, ms: f64, err: f64) -> Row {
        Row {
            scene: "a, \"b\".toml".into(),
            config: config.into(),
            method: "cpu".into(),
            quality: "draft".into(),
            rsl: 30,
            time: 1.5,
            prepare_ms: 12.5,
            prepare_bytes: 1000,
            prepare_built: 3,
            ms_per_frame: ms,
            relative_l2: err,
            mean_relative: 0.1,
            p95_relative: 0.3,
            truth_noise: 0.01,
            truth_spp: 64,
            mc_spp: Some(20.0),
            mc_ms: None,
            pixel_l2: Some((0.5, 0.25)),
            objects: vec![("floor".into(), 0.05, 0.01), ("ball".into(), 0.5, 0.02)],
            pixel_objects: vec![("floor".into(), 0.0625, 0.015), ("ball".into(), 0.75, 0.03)],
            image_ms: Some(4.0 * ms + 0.5),
            truth_key: Some(0x0123_4567_89ab_cdef),
        }
    }

    #[test]
    fn the_truths_noise_is_taken_out_in_quadrature() {
        assert_eq!(with_noise(0.05, 0.03), "5.00% (3.00%)");
        assert_eq!(with_noise(0.02, 0.03), "2.00% (3.00%, within noise)");
        assert_eq!(less_noise(0.05, 0.03), "4.00%");
        assert_eq!(less_noise(0.13, 0.05), "12.00%");
        assert_eq!(less_noise(0.03, 0.04), "within noise");
        assert_eq!(less_noise(0.04, 0.04), "within noise");
    }

    /// `results.csv` as written before rows carried their last `columns` columns (the image's
    /// frame time, then the per-object pixel errors): those dropped.
    fn good_without(csv: &str, columns: usize) -> String {
        let cut = |l: &str| (0..columns).fold(l.to_string(), |l, _| l[..l.rfind(',').unwrap()].to_string());
        csv.lines().map(|l| format!("{}\n", cut(l))).collect()
    }

    #[test]
    fn rows_round_trip_through_csv() {
        let dir = rsl_sphere::scratch::Scratch::new("bench-report");
        let rows =
            vec![row("method=cpu quality=draft rsl=30", 5.0, 0.25), row("method=cpu quality=paper rsl=30", 9.0, 0.125)];
        let path = dir.join("results.csv");
        write_rows(&path, &rows).unwrap();
        assert_eq!(read_rows(&path).unwrap(), rows);
        write_reports(&dir, "rsl bench s.toml --out dir", &rows, &[], false).unwrap();
        let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
        assert!(md.starts_with("# rsl bench\n\nWritten by:\n\n```sh\nrsl bench s.toml --out dir\n```\n"), "{md}");
        assert!(md.contains("★ method=cpu quality=draft rsl=30") && md.contains("★ method=cpu quality=paper rsl=30"));
        assert!(
            md.contains(
                "| method=cpu quality=draft rsl=30 | 20.5 | 50.00% (25.00%; less noise 43.30%) | 6.25% (1.50%) | 75.00% (3.00%) |"
            ),
            "{md}"
        );
        let objects = std::fs::read_to_string(dir.join("objects.csv")).unwrap();
        assert!(objects.contains(",floor,0.05,0.01,0.0625,0.015\n"), "{objects}");
        // Results written before the images' frame times, and before the per-object pixel
        // errors, are read without them.
        let written = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, good_without(&written, 1)).unwrap();
        let read = read_rows(&path).unwrap();
        assert!(read.iter().all(|r| r.image_ms.is_none()) && read[0].pixel_objects == rows[0].pixel_objects);
        std::fs::write(&path, good_without(&written, 2)).unwrap();
        let read = read_rows(&path).unwrap();
        assert!(read.iter().all(|r| r.pixel_objects.is_empty()) && read[0].objects == rows[0].objects);
        // Without a frame time the image's column says so.
        let untimed: Vec<Row> = rows.iter().map(|r| Row { image_ms: None, ..r.clone() }).collect();
        let (md, _) = reports("", &untimed, &[], false, &|_| false);
        assert!(md.contains("| method=cpu quality=draft rsl=30 | — | 50.00% (25.00%;"), "{md}");
        write_rows(&path, &rows).unwrap();
        assert!(
            dir.join("a___b__error_vs_ms.svg").exists() && dir.join("a___b__pixel_error_vs_ms.svg").exists(),
            "{:?}",
            std::fs::read_dir(&dir).unwrap().collect::<Vec<_>>()
        );
        // A saved row with a value no bench writes is refused by its column's name.
        let good = std::fs::read_to_string(&path).unwrap();
        for (from, to, says) in [
            (",5,0.25,", ",NaN,0.25,", "ms_per_frame is NaN"),
            (",5,0.25,", ",-5,0.25,", "ms_per_frame is -5"),
            (",1.5,12.5,", ",inf,12.5,", "time is inf"),
            ("floor=0.05/", "floor=NaN/", "floor relative_l2 is NaN"),
        ] {
            assert!(good.contains(from), "{good}");
            std::fs::write(&path, good.replacen(from, to, 1)).unwrap();
            let e = read_rows(&path).unwrap_err().to_string();
            assert!(e.contains(says) && e.contains("line 2"), "{e}");
        }
        std::fs::write(&path, "something else\n").unwrap();
        assert!(read_rows(&path).unwrap_err().to_string().contains("header"));
        assert!(read_rows(&dir.join("missing.csv")).unwrap().is_empty());
    }
}
