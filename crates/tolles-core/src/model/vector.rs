//! A time series of 3-component vectors, such as a fluxgate's readings.

/// Three equally long component series (body frame FRD unless stated otherwise).
///
/// ```
/// use tolles_core::model::vector::VectorSeries;
/// let b = VectorSeries::new(vec![3.0], vec![4.0], vec![12.0]);
/// assert_eq!(b.magnitude(0), 13.0);
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VectorSeries {
    /// x (forward) component, nT.
    pub x: Vec<f64>,
    /// y (right) component, nT.
    pub y: Vec<f64>,
    /// z (down) component, nT.
    pub z: Vec<f64>,
}

impl From<[Vec<f64>; 3]> for VectorSeries {
    /// The series of components `[x, y, z]` (nT), as a table's three columns give them.
    fn from([x, y, z]: [Vec<f64>; 3]) -> Self {
        Self::new(x, y, z)
    }
}

impl VectorSeries {
    /// Builds a series from its components (nT).
    ///
    /// # Panics
    /// If the three components differ in length: that is a programming error, not bad input.
    pub fn new(x: Vec<f64>, y: Vec<f64>, z: Vec<f64>) -> Self {
        assert!(
            x.len() == y.len() && y.len() == z.len(),
            "vector components must have equal lengths"
        );
        Self { x, y, z }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Takes a constant `offset` (nT; x, y, z) out of every sample, in place.
    pub fn remove_offset(&mut self, offset: [f64; 3]) {
        for (c, o) in [&mut self.x, &mut self.y, &mut self.z]
            .into_iter()
            .zip(offset)
        {
            c.iter_mut().for_each(|v| *v -= o);
        }
    }

    /// Sample `k` as an array `[x, y, z]` (nT).
    pub fn at(&self, k: usize) -> [f64; 3] {
        [self.x[k], self.y[k], self.z[k]]
    }

    /// Euclidean magnitude of sample `k` (nT); finite whenever the components are, even when
    /// their squares would overflow (a corrupt 1e155 nT cell must read as huge, not infinite).
    pub fn magnitude(&self, k: usize) -> f64 {
        norm3(self.at(k))
    }

    /// True when all three components of sample `k` are finite.
    pub fn is_finite(&self, k: usize) -> bool {
        self.at(k).iter().all(|v| v.is_finite())
    }

    /// The samples in `range` as a new series.
    pub fn slice(&self, range: std::ops::Range<usize>) -> Self {
        Self {
            x: self.x[range.clone()].to_vec(),
            y: self.y[range.clone()].to_vec(),
            z: self.z[range].to_vec(),
        }
    }
}

/// The exponent bits of an f64: all set for an infinity or a NaN.
const EXPONENT: u64 = 0x7ff0_0000_0000_0000;

/// `‖v‖` without overflow or underflow: the plain sum of squares when it is safely in range
/// (the common case, bit-identical to the naive formula), else scaled by the largest component.
pub fn norm3(v: [f64; 3]) -> f64 {
    let squares = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if squares.is_finite() && squares > f64::MIN_POSITIVE {
        return squares.sqrt();
    }
    if v.iter().any(|c| c.is_nan()) {
        return f64::NAN;
    }
    let scale = v.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if scale == 0.0 || scale.is_infinite() {
        return scale;
    }
    let [x, y, z] = v.map(|c| c / scale);
    scale * (x * x + y * y + z * z).sqrt()
}

/// [`norm3`] of every sample of the components `v` (x, y, z, equally long) into `out`, the
/// same values to the bit.
///
/// The common case, a sum of squares safely in range, is one loop the compiler vectorises
/// (a call of `norm3` per sample, with its branches, stays scalar); a block with any sample
/// outside it (NaN, infinite, tiny) is gone through again, those samples by `norm3`.
///
/// # Panics
/// If the slices differ in length: a programming error.
#[inline(always)]
pub fn norms3_into(v: [&[f64]; 3], out: &mut [f64]) {
    assert!(
        v.iter().all(|c| c.len() == out.len()),
        "components and output equally long"
    );
    let [x, y, z] = v;
    let squares = |x: &f64, y: &f64, z: &f64| x * x + y * y + z * z;
    let in_range = |s: f64| s.is_finite() && s > f64::MIN_POSITIVE;
    let components = || x.iter().zip(y).zip(z);
    let mut all_in_range = true;
    for (o, ((x, y), z)) in out.iter_mut().zip(components()) {
        let s = squares(x, y, z);
        all_in_range &= in_range(s);
        *o = s.sqrt();
    }
    if all_in_range {
        return;
    }
    for (o, ((x, y), z)) in out.iter_mut().zip(components()) {
        if !in_range(squares(x, y, z)) {
            *o = norm3([*x, *y, *z]);
        }
    }
}

/// One or more fluxgates sampled together: the input of a design over several fluxgates.
///
/// A single series converts into it, so every function taking `impl Into<Fluxgates>` also
/// takes `&VectorSeries`.
///
/// ```
/// use tolles_core::model::vector::{Fluxgates, VectorSeries};
/// let a = VectorSeries::new(vec![1.0, 2.0], vec![0.0; 2], vec![0.0; 2]);
/// let b = VectorSeries::new(vec![3.0, f64::NAN], vec![0.0; 2], vec![0.0; 2]);
/// let both = Fluxgates::from(vec![&a, &b]);
/// assert_eq!((both.count(), both.len()), (2, 2));
/// assert!(both.is_finite(0) && !both.is_finite(1));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Fluxgates<'a>(Vec<&'a VectorSeries>, Vec<&'a [f64]>);

/// Fluxgates and extra channels cut to one range of samples (see [`Fluxgates::slice`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SlicedInputs {
    /// The fluxgates (nT).
    pub series: Vec<VectorSeries>,
    /// The extra channels (their own units, e.g. A).
    pub extras: Vec<Vec<f64>>,
}

impl<'a> From<&'a SlicedInputs> for Fluxgates<'a> {
    fn from(s: &'a SlicedInputs) -> Self {
        Fluxgates(
            s.series.iter().collect(),
            s.extras.iter().map(Vec::as_slice).collect(),
        )
    }
}

impl<'a> Fluxgates<'a> {
    /// The same fluxgates with extra channels sampled with them (e.g. currents, A), in the
    /// order a design's `extras` names them.
    pub fn with_extras(self, extras: Vec<&'a [f64]>) -> Self {
        Fluxgates(self.0, extras)
    }

    /// The extra channels.
    pub fn extras(&self) -> &[&'a [f64]] {
        &self.1
    }

    /// The series, in design order.
    pub fn series(&self) -> &[&'a VectorSeries] {
        &self.0
    }

    /// Number of fluxgates.
    pub fn count(&self) -> usize {
        self.0.len()
    }

    /// Number of samples (that of the first fluxgate; see [`Fluxgates::equal_lengths`]).
    pub fn len(&self) -> usize {
        self.0.first().map_or(0, |s| s.len())
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// True when every fluxgate and extra channel has as many samples as the first fluxgate.
    pub fn equal_lengths(&self) -> bool {
        self.0.iter().all(|s| s.len() == self.len()) && self.1.iter().all(|e| e.len() == self.len())
    }

    /// [`Fluxgates::is_finite`] of every sample, a column at a time (so it vectorises), by
    /// parts of the samples on all cores.
    pub fn finite_mask(&self) -> Vec<bool> {
        let mut mask = vec![true; self.len()];
        crate::parallel::split_items(&mut mask, |rows, mask| {
            let columns = self.0.iter().flat_map(|s| [&s.x[..], &s.y[..], &s.z[..]]);
            for column in columns.chain(self.1.iter().copied()) {
                // Bytes and a comparison of the exponent bits: a loop the compiler vectorises.
                let part = &column[rows.start.min(column.len())..rows.end.min(column.len())];
                for (m, v) in mask.iter_mut().zip(part) {
                    *m &= v.to_bits() & EXPONENT != EXPONENT;
                }
            }
        });
        mask
    }

    /// True when every component of every fluxgate, and every extra channel, is finite at
    /// sample `k`.
    pub fn is_finite(&self, k: usize) -> bool {
        self.0.iter().all(|s| s.is_finite(k)) && self.1.iter().all(|e| e[k].is_finite())
    }

    /// Every fluxgate's and extra channel's samples in `range`, as new series.
    pub fn slice(&self, range: std::ops::Range<usize>) -> SlicedInputs {
        SlicedInputs {
            series: self.0.iter().map(|s| s.slice(range.clone())).collect(),
            extras: self.1.iter().map(|e| e[range.clone()].to_vec()).collect(),
        }
    }
}

impl<'a> From<&'a VectorSeries> for Fluxgates<'a> {
    fn from(series: &'a VectorSeries) -> Self {
        Fluxgates(vec![series], Vec::new())
    }
}

impl<'a> From<Vec<&'a VectorSeries>> for Fluxgates<'a> {
    fn from(series: Vec<&'a VectorSeries>) -> Self {
        Fluxgates(series, Vec::new())
    }
}

impl<'a> From<&'a [VectorSeries]> for Fluxgates<'a> {
    fn from(series: &'a [VectorSeries]) -> Self {
        Fluxgates(series.iter().collect(), Vec::new())
    }
}

impl<'a> From<&'a Vec<VectorSeries>> for Fluxgates<'a> {
    fn from(series: &'a Vec<VectorSeries>) -> Self {
        Fluxgates(series.iter().collect(), Vec::new())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_finite_mask_is_each_sample_finite() {
        let odd = [
            0.0,
            -0.0,
            1e308,
            -5e-324,
            2.5,
            -3.0,
            7.0,
            1.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let n = 2000;
        // Mostly finite, each column's non-finite values at its own samples.
        let column = |shift: usize| -> Vec<f64> {
            (0..n)
                .map(|k| odd[(k * 7 + shift * 3) % 17 % odd.len()])
                .collect()
        };
        let (a, b) = (
            VectorSeries::new(column(0), column(1), column(2)),
            VectorSeries::new(column(3), vec![1.0; n], column(5)),
        );
        let extra = column(6);
        let flux = Fluxgates::from(vec![&a, &b]).with_extras(vec![&extra]);
        let mask = flux.finite_mask();
        assert_eq!(mask, (0..n).map(|k| flux.is_finite(k)).collect::<Vec<_>>());
        assert!(mask.iter().any(|m| *m) && mask.iter().any(|m| !*m));
    }

    #[test]
    fn norms_of_a_block_are_norm3_to_the_bit_odd_samples_included() {
        let odd = [
            0.0,
            -0.0,
            1e155,
            -1e200,
            3e-200,
            -5e-324,
            2.5,
            4e4,
            f64::NAN,
            f64::INFINITY,
        ];
        let plain = |k: usize| 20_000.0 + 1_000.0 * (k as f64 * 0.37).sin();
        for with_odd in [false, true] {
            let n = 300;
            let column = |shift: usize| -> Vec<f64> {
                (0..n)
                    .map(|k| match with_odd && k % 13 == shift {
                        true => odd[(k + shift) % odd.len()],
                        false => plain(k + 100 * shift),
                    })
                    .collect()
            };
            let v = [column(0), column(1), column(2)];
            let mut out = vec![f64::NAN; n];
            norms3_into([&v[0], &v[1], &v[2]], &mut out);
            for (k, o) in out.iter().enumerate() {
                let want = norm3([v[0][k], v[1][k], v[2][k]]);
                assert!(
                    o.to_bits() == want.to_bits() || (o.is_nan() && want.is_nan()),
                    "{k}"
                );
            }
        }
    }

    #[test]
    fn magnitude_does_not_overflow_or_hide_nan() {
        let b = VectorSeries::new(
            vec![1e155, 3e-200, f64::NAN, 0.0, f64::INFINITY],
            vec![0.0, 4e-200, 1.0, 0.0, 1.0],
            vec![1e155, 0.0, 1.0, 0.0, 1.0],
        );
        assert!((b.magnitude(0) / (1e155 * 2f64.sqrt()) - 1.0).abs() < 1e-15);
        assert!((b.magnitude(1) / 5e-200 - 1.0).abs() < 1e-15);
        assert!(b.magnitude(2).is_nan());
        assert_eq!(b.magnitude(3), 0.0);
        assert_eq!(b.magnitude(4), f64::INFINITY);
    }
}
