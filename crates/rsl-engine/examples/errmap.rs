//! scratch
use std::path::Path;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a[1] == "at" {
        let imgs: Vec<_> = a[3..].iter().map(|f| rsl_engine::output::read_exr(Path::new(f)).unwrap()).collect();
        for xy in a[2].split(';') {
            let v: Vec<u32> = xy.split(',').map(|x| x.parse().unwrap()).collect();
            let line: Vec<String> = imgs
                .iter()
                .map(|im| {
                    let c = im.2[(v[1] * im.0 + v[0]) as usize];
                    format!("{:8.3}", c.dot(glam::Vec3::new(0.2126, 0.7152, 0.0722)))
                })
                .collect();
            println!("({}, {}): {}", v[0], v[1], line.join(" "));
        }
        return;
    }
    let (w, h, t, m) = rsl_engine::output::read_exr(Path::new(&a[1])).unwrap();
    let (_, _, r, _) = rsl_engine::output::read_exr(Path::new(&a[2])).unwrap();
    let m = m.unwrap();
    let lum = |c: glam::Vec3| c.dot(glam::Vec3::new(0.2126, 0.7152, 0.0722)) as f64;
    let mut errs: Vec<(f64, usize)> = Vec::new();
    let (mut num, mut den, mut over, mut under) = (0.0, 0.0, 0.0, 0.0);
    for i in 0..t.len() {
        if !m[i] {
            continue;
        }
        let d = (t[i] - r[i]).length_squared() as f64;
        num += d;
        den += r[i].length_squared() as f64;
        if lum(t[i]) > lum(r[i]) {
            over += d
        } else {
            under += d
        }
        errs.push((d, i));
    }
    errs.sort_by(|a, b| b.0.total_cmp(&a.0));
    println!("rel {:.4} over {:.2} under {:.2}", (num / den).sqrt(), over / num, under / num);
    for f in [0.001, 0.01, 0.05, 0.2] {
        let n = (errs.len() as f64 * f) as usize;
        let s: f64 = errs[..n].iter().map(|e| e.0).sum();
        println!("top {:.1}% pixels: {:.1}% of squared error", f * 100.0, 100.0 * s / num);
    }
    for e in &errs[..12] {
        let i = e.1;
        println!("px ({}, {}) test {:.3} truth {:.3}", i as u32 % w, i as u32 / w, lum(t[i]), lum(r[i]));
    }
    // log error map as PGM
    let mut out = format!("P2\n{w} {h}\n255\n");
    let max = errs[0].0.sqrt();
    for i in 0..t.len() {
        let e = if m[i] { (t[i] - r[i]).length() as f64 } else { 0.0 };
        let v = if e > 0.0 { ((e / max).log10() + 4.0).max(0.0) / 4.0 * 255.0 } else { 0.0 };
        out += &format!("{} ", v as u32);
    }
    std::fs::write(&a[3], out).unwrap();
}
