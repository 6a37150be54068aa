//! The tests of `ssm::device`.

use ssm::device::*;

#[test]
fn device_exponent_order_is_graded_descending_lexicographic() {
    assert_eq!(
        device_exponents(2, 3),
        vec![vec![2, 0], vec![1, 1], vec![0, 2], vec![3, 0], vec![2, 1], vec![1, 2], vec![0, 3]]
    );
    assert_eq!(device_exponents(4, 3).len(), shared::model::lift_terms(4, 3).unwrap());
}
