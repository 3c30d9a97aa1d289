//! Which vector kernels the lookups may use: the widest the processor has, or fewer when
//! the environment variable `RSL_SIMD` asks for them (`portable`, `avx2`, `avx512`, or
//! `auto`, the default) — for comparing the paths' speed and results on one machine.
//!
//! The choice is made once per process. An unknown value is reported once on standard
//! error and treated as `auto`; asking for more than the processor has gives what it has.

use std::sync::OnceLock;

/// Vector instruction sets the kernels are written for, in increasing width.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Plain Rust, no explicit vector instructions.
    Portable,
    /// AVX2 with fused multiply-add (eight `f32` or four `f64` lanes).
    Avx2,
    /// AVX-512F on top of AVX2 and FMA (sixteen `f32` or eight `f64` lanes).
    Avx512,
}

impl Level {
    /// The level named by `RSL_SIMD`'s value, `None` for `auto`, or an error for anything else.
    pub fn parse(value: &str) -> Result<Option<Level>, String> {
        match value.trim().to_ascii_lowercase().as_str() {
            "" | "auto" => Ok(None),
            "portable" => Ok(Some(Level::Portable)),
            "avx2" => Ok(Some(Level::Avx2)),
            "avx512" => Ok(Some(Level::Avx512)),
            other => Err(format!("RSL_SIMD={other} is not one of auto, avx512, avx2, portable; using auto")),
        }
    }
}

/// The widest level this processor runs.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        let avx2 = std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma");
        if avx2 && std::is_x86_feature_detected!("avx512f") {
            return Level::Avx512;
        }
        if avx2 {
            return Level::Avx2;
        }
    }
    Level::Portable
}

/// The level the lookups use: [`detected`], capped by `RSL_SIMD` (read once).
pub fn level() -> Level {
    static LEVEL: OnceLock<Level> = OnceLock::new();
    *LEVEL.get_or_init(|| {
        let asked = match std::env::var("RSL_SIMD") {
            Ok(v) => Level::parse(&v).unwrap_or_else(|e| {
                eprintln!("warning: {e}");
                None
            }),
            Err(_) => None,
        };
        asked.map_or(detected(), |a| a.min(detected()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_and_unknown_ones_are_errors() {
        assert_eq!(Level::parse("auto"), Ok(None));
        assert_eq!(Level::parse(""), Ok(None));
        assert_eq!(Level::parse(" AVX2 "), Ok(Some(Level::Avx2)));
        assert_eq!(Level::parse("portable"), Ok(Some(Level::Portable)));
        assert_eq!(Level::parse("avx512"), Ok(Some(Level::Avx512)));
        assert!(Level::parse("sse9").unwrap_err().contains("RSL_SIMD=sse9"));
        assert!(Level::Portable < Level::Avx2 && Level::Avx2 < Level::Avx512);
        assert!(level() <= detected());
    }
}
