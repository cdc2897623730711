//! Sums and lengths of 3-vectors (`[x, y, z]` in any one frame and unit: nT, metres, …),
//! shared by the simulation and its cabin effects.

/// `a + b`, component by component (units of `a` and `b`).
pub(super) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// The Euclidean length of `v` (units of `v`).
pub(super) fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
