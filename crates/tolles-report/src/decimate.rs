//! Thinning long series for display without losing what the eye would see.
//!
//! ```
//! use tolles_report::decimate::polylines;
//! let x: Vec<f64> = (0..100_000).map(|k| k as f64).collect();
//! let mut y: Vec<f64> = x.iter().map(|v| (v / 1000.0).sin()).collect();
//! y[50_000] = f64::NAN; // a gap
//! y[70_000] = 25.0; // a spike that must stay visible
//! let lines = polylines(&x, &y, (0.0, 99_999.0), 500, |_| true);
//! assert_eq!(lines.len(), 2); // the gap breaks the line
//! let points: usize = lines.iter().map(|l| l.len()).sum();
//! assert!(points <= 4 * 500 + 4);
//! assert!(lines[1].iter().any(|&(_, v)| v == 25.0));
//! ```

/// Splits `(x, y)` into polylines at every point that is not drawable (non-finite x or y, or
/// `keep(y)` false, e.g. y ≤ 0 on a logarithmic axis) and thins each polyline to at most four
/// points per bucket: the first, the lowest, the highest and the last point of every run of
/// consecutive samples whose x falls in the same one of `buckets` equal slices of
/// `x_range` (one slice per pixel column keeps the drawn picture exact).
///
/// Points stay in input order; x outside `x_range` is counted in the nearest edge bucket.
pub fn polylines(
    x: &[f64],
    y: &[f64],
    x_range: (f64, f64),
    buckets: usize,
    keep: impl Fn(f64) -> bool,
) -> Vec<Vec<(f64, f64)>> {
    let bucket_of = bucket_index(x_range, buckets.max(1));
    let mut lines = Vec::new();
    let mut line: Vec<(f64, f64)> = Vec::new();
    let mut bucket: Option<Bucket> = None;
    for (k, (&xv, &yv)) in x.iter().zip(y).enumerate() {
        if !(xv.is_finite() && yv.is_finite() && keep(yv)) {
            if let Some(b) = bucket.take() {
                b.emit(x, y, &mut line);
            }
            if !line.is_empty() {
                lines.push(std::mem::take(&mut line));
            }
            continue;
        }
        let index = bucket_of(xv);
        match &mut bucket {
            Some(b) if b.index == index => b.add(k, yv, y),
            _ => {
                if let Some(b) = bucket.replace(Bucket::new(index, k)) {
                    b.emit(x, y, &mut line);
                }
            }
        }
    }
    if let Some(b) = bucket {
        b.emit(x, y, &mut line);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

fn bucket_index((lo, hi): (f64, f64), buckets: usize) -> impl Fn(f64) -> usize {
    let width = hi - lo;
    move |v| {
        if width > 0.0 {
            let t = ((v - lo) / width * buckets as f64).floor();
            t.clamp(0.0, (buckets - 1) as f64) as usize
        } else {
            0
        }
    }
}

/// Indices of the first, lowest, highest and last sample of one bucket.
struct Bucket {
    index: usize,
    first: usize,
    lowest: usize,
    highest: usize,
    last: usize,
}

impl Bucket {
    fn new(index: usize, k: usize) -> Self {
        Bucket {
            index,
            first: k,
            lowest: k,
            highest: k,
            last: k,
        }
    }

    fn add(&mut self, k: usize, v: f64, y: &[f64]) {
        if v < y[self.lowest] {
            self.lowest = k;
        }
        if v > y[self.highest] {
            self.highest = k;
        }
        self.last = k;
    }

    fn emit(&self, x: &[f64], y: &[f64], out: &mut Vec<(f64, f64)>) {
        let mut picked = [self.first, self.lowest, self.highest, self.last];
        picked.sort_unstable();
        let mut previous = None;
        for k in picked {
            if previous != Some(k) {
                out.push((x[k], y[k]));
                previous = Some(k);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_the_extremes_of_every_bucket() {
        let n = 200_000;
        let x: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = (0..n)
            .map(|k| ((k * 7919) % 1000) as f64 - 500.0 + if k == 123_457 { 1e4 } else { 0.0 })
            .collect();
        let lines = polylines(&x, &y, (0.0, x[n - 1]), 1000, |_| true);
        assert_eq!(lines.len(), 1);
        let line = &lines[0];
        assert!(line.len() <= 4000, "{} points", line.len());
        let max = line.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let min = line.iter().map(|p| p.1).fold(f64::MAX, f64::min);
        assert!(y[123_457] > 9000.0);
        assert_eq!(max, y[123_457]);
        assert_eq!(min, -500.0);
        // Every bucket's own extremes survive, not only the global ones.
        let per_bucket = n / 1000;
        for b in [0, 417, 999] {
            let slice = &y[b * per_bucket..(b + 1) * per_bucket];
            let hi = slice.iter().cloned().fold(f64::MIN, f64::max);
            let lo = slice.iter().cloned().fold(f64::MAX, f64::min);
            let (x0, x1) = (x[b * per_bucket], x[(b + 1) * per_bucket - 1]);
            let kept: Vec<f64> = line
                .iter()
                .filter(|p| p.0 >= x0 && p.0 <= x1)
                .map(|p| p.1)
                .collect();
            assert!(kept.contains(&hi) && kept.contains(&lo), "bucket {b}");
        }
        // Order is preserved.
        assert!(line.windows(2).all(|w| w[0].0 < w[1].0));
    }

    #[test]
    fn short_series_are_kept_whole() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [1.0, -1.0, 2.0, 0.5];
        let lines = polylines(&x, &y, (0.0, 3.0), 1000, |_| true);
        assert_eq!(
            lines,
            vec![vec![(0.0, 1.0), (1.0, -1.0), (2.0, 2.0), (3.0, 0.5)]]
        );
    }

    #[test]
    fn non_finite_values_break_the_line() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, f64::NAN, 7.0, 8.0];
        let y = [1.0, 2.0, f64::NAN, 3.0, f64::INFINITY, 4.0, 5.0, 6.0, 7.0];
        let lines = polylines(&x, &y, (0.0, 8.0), 100, |_| true);
        assert_eq!(
            lines,
            vec![
                vec![(0.0, 1.0), (1.0, 2.0)],
                vec![(3.0, 3.0)],
                vec![(5.0, 4.0)],
                vec![(7.0, 6.0), (8.0, 7.0)],
            ]
        );
    }

    #[test]
    fn values_a_log_axis_cannot_show_break_the_line() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [1.0, 0.0, 2.0, 3.0];
        let lines = polylines(&x, &y, (0.0, 3.0), 10, |v| v > 0.0);
        assert_eq!(lines, vec![vec![(0.0, 1.0)], vec![(2.0, 2.0), (3.0, 3.0)]]);
    }
}
