//! Strict fixed-size arrays for the TOML and JSON inputs: the toml crate
//! fills a `[f64; 4]` from the first four elements of a longer array and
//! ignores the rest, so `orientation = [0, 0, 0, 1, "x"]` would load. Every
//! fixed-size array field of a profile or rig file deserializes through
//! [`exact`], which requires exactly N elements.

use serde::{Deserialize, Deserializer};

/// Deserializes exactly `N` elements of `T` (serde `deserialize_with`).
pub(crate) fn exact<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let v: Vec<T> = Vec::deserialize(d)?;
    let n = v.len();
    v.try_into().map_err(|_| {
        serde::de::Error::custom(format!(
            "expected an array of {N} numbers, found {n} elements"
        ))
    })
}

/// Deserializes a list of points, each exactly 2 numbers.
pub(crate) fn points<'de, D>(d: D) -> Result<Option<Vec<[f64; 2]>>, D::Error>
where
    D: Deserializer<'de>,
{
    let v: Option<Vec<Vec<f64>>> = Option::deserialize(d)?;
    v.map(|list| {
        list.into_iter()
            .enumerate()
            .map(|(i, p)| {
                let n = p.len();
                <[f64; 2]>::try_from(p).map_err(|_| {
                    serde::de::Error::custom(format!(
                        "point {i} has {n} numbers; each point is [x, y]"
                    ))
                })
            })
            .collect()
    })
    .transpose()
}
