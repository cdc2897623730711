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

    /// Sample `k` as an array `[x, y, z]` (nT).
    pub fn at(&self, k: usize) -> [f64; 3] {
        [self.x[k], self.y[k], self.z[k]]
    }

    /// Euclidean magnitude of sample `k` (nT).
    pub fn magnitude(&self, k: usize) -> f64 {
        let [x, y, z] = self.at(k);
        (x * x + y * y + z * z).sqrt()
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
pub struct Fluxgates<'a>(Vec<&'a VectorSeries>);

impl<'a> Fluxgates<'a> {
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

    /// True when every fluxgate has as many samples as the first.
    pub fn equal_lengths(&self) -> bool {
        self.0.iter().all(|s| s.len() == self.len())
    }

    /// True when every component of every fluxgate is finite at sample `k`.
    pub fn is_finite(&self, k: usize) -> bool {
        self.0.iter().all(|s| s.is_finite(k))
    }

    /// Every fluxgate's samples in `range`, as new series.
    pub fn slice(&self, range: std::ops::Range<usize>) -> Vec<VectorSeries> {
        self.0.iter().map(|s| s.slice(range.clone())).collect()
    }
}

impl<'a> From<&'a VectorSeries> for Fluxgates<'a> {
    fn from(series: &'a VectorSeries) -> Self {
        Fluxgates(vec![series])
    }
}

impl<'a> From<Vec<&'a VectorSeries>> for Fluxgates<'a> {
    fn from(series: Vec<&'a VectorSeries>) -> Self {
        Fluxgates(series)
    }
}

impl<'a> From<&'a [VectorSeries]> for Fluxgates<'a> {
    fn from(series: &'a [VectorSeries]) -> Self {
        Fluxgates(series.iter().collect())
    }
}

impl<'a> From<&'a Vec<VectorSeries>> for Fluxgates<'a> {
    fn from(series: &'a Vec<VectorSeries>) -> Self {
        Fluxgates(series.iter().collect())
    }
}
