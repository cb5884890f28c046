//! Checked count arithmetic: every product or sum of counts taken from an
//! input (grid cells, instances × placements, totals) goes through these,
//! so a value that would wrap is an error before anything is allocated.

/// The product of `factors`, or None when it overflows `u64`.
pub fn product(factors: impl IntoIterator<Item = u64>) -> Option<u64> {
    factors
        .into_iter()
        .try_fold(1u64, |acc, f| acc.checked_mul(f))
}

/// The sum of `terms`, or None when it overflows `u64`.
pub fn sum(terms: impl IntoIterator<Item = u64>) -> Option<u64> {
    terms
        .into_iter()
        .try_fold(0u64, |acc, t| acc.checked_add(t))
}

/// `value` when it is within `1..=max`; else a message naming `what`, the
/// value (or that it overflows) and the bound.
pub fn within(what: &str, value: Option<u64>, max: u64) -> Result<u64, String> {
    match value {
        Some(v) if (1..=max).contains(&v) => Ok(v),
        Some(0) => Err(format!("{what} is 0; it must be within 1..={max}")),
        Some(v) => Err(format!("{what} is {v}, over the limit of {max}")),
        None => Err(format!(
            "{what} overflows a 64-bit count; it must be within 1..={max}"
        )),
    }
}

/// Bytes of `count` values of `T`, or None when it overflows.
pub fn bytes_of<T>(count: u64) -> Option<u64> {
    count.checked_mul(std::mem::size_of::<T>() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping_products_are_caught() {
        assert_eq!(product([2, 3, 4]), Some(24));
        assert_eq!(product([u32::MAX as u64; 3]), None);
        // 2^31 · 2^31 · 4 = 2^64 wraps to 0 in unchecked arithmetic.
        assert_eq!(product([1 << 31, 1 << 31, 4]), None);
        assert_eq!(sum([u64::MAX, 1]), None);
        let e = within("grid cells", product([1 << 31, 1 << 31, 4]), 10).unwrap_err();
        assert!(e.contains("overflows"), "{e}");
        assert!(within("n", Some(0), 10).unwrap_err().contains("is 0"));
        assert!(within("n", Some(11), 10)
            .unwrap_err()
            .contains("over the limit of 10"));
        assert_eq!(within("n", Some(10), 10), Ok(10));
        assert_eq!(bytes_of::<u64>(u64::MAX / 4), None);
    }
}
