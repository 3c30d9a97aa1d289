//! The one approximate-equality check the workspace's tests use.
//!
//! It panics with the actual difference, the tolerance and what was compared, so a failing
//! test says by how much it failed.

/// Relative difference `|a − b| / max(|b|, floor)`; `floor` keeps values near zero from
/// turning tiny absolute differences into huge relative ones.
pub fn rel_diff(actual: f64, expected: f64, floor: f64) -> f64 {
    (actual - expected).abs() / expected.abs().max(floor)
}

/// Asserts that `actual` is within `rel_tol` of `expected`, relative to
/// `max(|expected|, floor)`. Non-finite values always fail.
#[track_caller]
pub fn assert_close(what: &str, actual: f64, expected: f64, rel_tol: f64, floor: f64) {
    let d = rel_diff(actual, expected, floor);
    assert!(
        actual.is_finite() && expected.is_finite() && d <= rel_tol,
        "{what}: actual {actual:e}, expected {expected:e}, |diff| {:e}, relative {d:e} > tolerance {rel_tol:e}",
        (actual - expected).abs()
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_within_and_rejects_outside() {
        assert_close("same", 1.0, 1.0 + 1e-12, 1e-9, 0.0);
        let r = std::panic::catch_unwind(|| assert_close("off", 1.1, 1.0, 1e-3, 0.0));
        assert!(r.is_err());
        let r = std::panic::catch_unwind(|| assert_close("nan", f64::NAN, 1.0, 1.0, 0.0));
        assert!(r.is_err());
    }
}
