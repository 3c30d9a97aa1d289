//! Property tests (proptest) of the coverage function: the visible fraction of a rotatable
//! square against a straight boundary, against its exact form and its symmetries.

use proptest::prelude::*;
use rsl_vis::coverage::{coverage, coverage_exact};

proptest! {
    #[test]
    fn coverage_is_a_fraction_that_rises_with_distance(d in -2.0f32..2.0, e in 0.0f32..0.5, r in 1e-4f32..1.5) {
        let c = coverage(d, r);
        prop_assert!((0.0..=1.0).contains(&c), "{}", c);
        prop_assert!(coverage(d + e, r) >= c - 1e-6, "not monotone at d = {}", d);
    }

    #[test]
    fn what_one_side_hides_the_other_shows(d in -2.0f32..2.0, r in 1e-3f32..1.5) {
        // A square centred at d and its mirror image at −d split the square between them.
        let sum = coverage(d, r) + coverage(-d, r);
        prop_assert!((sum - 1.0).abs() < 2e-3, "{}", sum);
    }

    #[test]
    fn the_table_follows_the_exact_coverage(t in -1.0f64..1.0, r in 0.01f32..1.0) {
        let d = (t * f64::from(r)) as f32;
        let exact = coverage_exact(f64::from(d) / f64::from(r));
        prop_assert!((f64::from(coverage(d, r)) - exact).abs() < 2e-3, "{} vs {}", coverage(d, r), exact);
    }

    #[test]
    fn a_square_wholly_on_one_side_is_wholly_seen_or_hidden(r in 1e-3f32..1.5, k in 1.0f32..5.0) {
        prop_assert_eq!(coverage(k * r, r), 1.0);
        prop_assert_eq!(coverage(-k * r, r), 0.0);
    }
}
