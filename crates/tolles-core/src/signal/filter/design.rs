//! Butterworth design: the analog prototype's poles, prewarped and moved to low-, high- or
//! band-pass, through the bilinear transform to second-order sections ordered as scipy orders
//! them.

use std::f64::consts::PI;
use std::ops::{Add, Div, Mul, Sub};

/// Sample rate (in units of the Nyquist frequency, so 2) that the analog design uses;
/// the bilinear transform then needs `2 * DESIGN_FS`.
const DESIGN_FS: f64 = 2.0;

/// Analog angular frequency that the bilinear transform maps onto the normalized
/// digital cutoff `wn`, so the -3 dB point lands exactly where requested.
pub(super) fn prewarp(wn: f64) -> f64 {
    2.0 * DESIGN_FS * (PI * wn / DESIGN_FS).tan()
}

/// Minimal complex arithmetic for pole placement; poles never need more.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct C {
    re: f64,
    im: f64,
}

impl C {
    pub(super) fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }

    pub(super) fn real(re: f64) -> Self {
        Self { re, im: 0.0 }
    }

    fn conj(self) -> Self {
        Self::new(self.re, -self.im)
    }

    pub(super) fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }

    /// Principal square root; either branch would do since both signs are used.
    fn sqrt(self) -> Self {
        let r = self.abs();
        let re = ((r + self.re) / 2.0).sqrt();
        let im = ((r - self.re) / 2.0).sqrt();
        Self::new(re, if self.im < 0.0 { -im } else { im })
    }
}

impl Add for C {
    type Output = C;
    fn add(self, o: C) -> C {
        C::new(self.re + o.re, self.im + o.im)
    }
}

impl Sub for C {
    type Output = C;
    fn sub(self, o: C) -> C {
        C::new(self.re - o.re, self.im - o.im)
    }
}

impl Mul for C {
    type Output = C;
    fn mul(self, o: C) -> C {
        C::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}

impl Div for C {
    type Output = C;
    fn div(self, o: C) -> C {
        let d = o.re * o.re + o.im * o.im;
        C::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
}

/// Where a filter's zeros sit, which fixes the numerators of its sections.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// Analog: none. Digital: all at z = -1 (Nyquist).
    Low,
    /// Analog: all at s = 0. Digital: all at z = +1 (DC).
    High,
    /// Analog: half at s = 0. Digital: half at z = +1, half at z = -1.
    Band,
}

/// Poles in the s- or z-plane grouped into real second-order factors (each pair is
/// either complex-conjugate or two reals), plus at most one lone real pole.
#[derive(Debug, Clone)]
pub(super) struct Zpk {
    kind: Kind,
    pairs: Vec<[C; 2]>,
    single: Option<f64>,
    /// Zeros at the origin (analog) — these become zeros at z = +1.
    origin_zeros: usize,
    gain: f64,
}

/// Upper-half-plane poles of the normalized analog Butterworth prototype (on the unit
/// circle of the left half-plane), and whether the real pole at -1 is present.
fn prototype(order: usize) -> (Vec<C>, bool) {
    // Poles are -exp(i·π·m / 2N) for m = 1-N, 3-N, ..., N-1; m < 0 gives Im > 0.
    let upper = (1..=order / 2)
        .map(|k| {
            let m = (2 * k) as f64 - 1.0 - order as f64;
            let theta = PI * m / (2 * order) as f64;
            C::new(-theta.cos(), -theta.sin())
        })
        .collect();
    (upper, order % 2 == 1)
}

pub(super) fn lowpass(order: usize, wo: f64) -> Zpk {
    let (upper, odd) = prototype(order);
    let scale = C::real(wo);
    Zpk {
        kind: Kind::Low,
        pairs: upper.iter().map(|&p| conj_pair(p * scale)).collect(),
        single: odd.then_some(-wo),
        origin_zeros: 0,
        gain: wo.powi(order as i32),
    }
}

pub(super) fn highpass(order: usize, wo: f64) -> Zpk {
    let (upper, odd) = prototype(order);
    let wo_c = C::real(wo);
    // Gain 1 / prod(-p) keeps |H| = 1 at infinite frequency; it is 1 up to rounding
    // for Butterworth poles, but computing it mirrors scipy's rounding.
    // The real prototype pole -1 contributes a factor 1.
    let prod = upper.iter().fold(C::real(1.0), |acc, &p| {
        acc * (C::real(0.0) - p) * (C::real(0.0) - p.conj())
    });
    Zpk {
        kind: Kind::High,
        pairs: upper.iter().map(|&p| conj_pair(wo_c / p)).collect(),
        single: odd.then_some(-wo),
        origin_zeros: order,
        gain: 1.0 / prod.re,
    }
}

pub(super) fn bandpass(order: usize, lo: f64, hi: f64) -> Zpk {
    let (upper, odd) = prototype(order);
    let (wo, bw) = ((lo * hi).sqrt(), hi - lo);
    let half_bw = C::real(bw / 2.0);
    let wo2 = C::real(wo * wo);
    // Each prototype pole p splits into p·bw/2 ± sqrt((p·bw/2)² - wo²).
    let split = |p: C| {
        let pl = p * half_bw;
        let d = (pl * pl - wo2).sqrt();
        (pl + d, pl - d)
    };
    let mut pairs = Vec::with_capacity(order);
    for &p in &upper {
        let (p1, p2) = split(p);
        pairs.push(conj_pair(p1));
        pairs.push(conj_pair(p2));
    }
    if odd {
        // The real prototype pole gives a conjugate pair or two real poles; both are
        // one real second-order factor.
        let (p1, p2) = split(C::real(-1.0));
        pairs.push([p1, p2]);
    }
    Zpk {
        kind: Kind::Band,
        pairs,
        single: None,
        origin_zeros: order,
        gain: bw.powi(order as i32),
    }
}

fn conj_pair(p: C) -> [C; 2] {
    [p, p.conj()]
}

/// Bilinear transform s = 2·fs·(z - 1)/(z + 1) of an analog design with `DESIGN_FS`.
pub(super) fn bilinear(analog: Zpk) -> Zpk {
    let fs2 = C::real(2.0 * DESIGN_FS);
    let map = |p: C| (fs2 + p) / (fs2 - p);
    // The gain absorbs the factors (fs2 - root) pulled out of each mapped root.
    let mut denom = C::real(1.0);
    for &[p1, p2] in &analog.pairs {
        denom = denom * (fs2 - p1) * (fs2 - p2);
    }
    if let Some(p) = analog.single {
        denom = denom * (fs2 - C::real(p));
    }
    let numer = fs2.re.powi(analog.origin_zeros as i32);
    Zpk {
        kind: analog.kind,
        pairs: analog
            .pairs
            .iter()
            .map(|&[p1, p2]| [map(p1), map(p2)])
            .collect(),
        single: analog.single.map(|p| map(C::real(p)).re),
        origin_zeros: analog.origin_zeros,
        gain: analog.gain * numer / denom.re,
    }
}

impl Zpk {
    /// Digital zpk to sections. Sections are ordered with poles farthest from the unit
    /// circle first (as scipy), and the overall gain goes into the first numerator.
    pub(super) fn into_sections(self) -> Vec<[f64; 6]> {
        let num = match self.kind {
            Kind::Low => [1.0, 2.0, 1.0],
            Kind::High => [1.0, -2.0, 1.0],
            Kind::Band => [1.0, 0.0, -1.0],
        };
        let mut pairs = self.pairs;
        pairs.sort_by(|a, b| (1.0 - b[0].abs()).total_cmp(&(1.0 - a[0].abs())));
        let mut sections: Vec<[f64; 6]> = Vec::with_capacity(pairs.len() + 1);
        if let Some(p) = self.single {
            // Padding the lone real pole and its zero with roots at the origin gives
            // b2 == a2 == 0, which scipy's padlen counts.
            // Its zero is at z = -1 (low-pass) or z = +1 (high-pass).
            let b1 = if self.kind == Kind::High { -1.0 } else { 1.0 };
            sections.push([1.0, b1, 0.0, 1.0, -p, 0.0]);
        }
        for [p1, p2] in pairs {
            let a1 = -(p1 + p2).re;
            let a2 = (p1 * p2).re;
            sections.push([num[0], num[1], num[2], 1.0, a1, a2]);
        }
        for b in &mut sections[0][..3] {
            *b *= self.gain;
        }
        sections
    }
}
