//! The compensation box scored while it is flown: each maneuver found as soon as it has ended
//! and its peak-to-peak before and after compensation (nT) measured, the figure of merit of
//! the maneuvers flown so far kept up to date. Time in s, attitude in deg, fields in nT.
//!
//! Causal: a sample is pushed once, and nothing waits for later ones beyond
//! [`LiveBoxSettings::settle_s`]. The batch scoring ([`super::fom`]) is run on a rolling window
//! of the last [`LiveBoxSettings::window_s`] seconds: a maneuver is taken when it ended at least
//! `settle_s` before the newest sample (so the zero-phase band-pass has settled after it), and
//! counted per slot (kind × cardinal heading) as the batch counts it, the largest swing kept.

use super::detect::{detect_maneuvers, Maneuver, ManeuverSettings};
use super::fom::{bandpassed, peak_to_peak, FomSettings, Slot};
use std::collections::VecDeque;

/// How the live box looks for maneuvers.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveBoxSettings {
    /// The maneuvers' detector, as the batch FOM's.
    pub maneuvers: ManeuverSettings,
    /// The band-pass of the peak-to-peaks, as the batch FOM's (0.05–1 Hz, order 4).
    pub fom: FomSettings,
    /// Seconds of flight kept and searched (s); longer than a maneuver and its margins.
    pub window_s: f64,
    /// How long after a maneuver's end it is scored (s).
    pub settle_s: f64,
    /// How often the window is searched (s of flight).
    pub every_s: f64,
}

impl Default for LiveBoxSettings {
    /// A 240 s window searched every 2 s; a maneuver scored 20 s after it ends (a 0.05 Hz
    /// fourth-order edge has settled by then).
    fn default() -> Self {
        Self {
            maneuvers: ManeuverSettings::default(),
            fom: FomSettings::default(),
            window_s: 240.0,
            settle_s: 20.0,
            every_s: 2.0,
        }
    }
}

/// A maneuver scored by the live box.
#[derive(Debug, Clone, PartialEq)]
pub struct FlownManeuver {
    /// The maneuver; its `start`/`end` index the window it was found in, `start_tt` and
    /// `end_tt` (s) place it in the flight.
    pub maneuver: Maneuver,
    /// Peak-to-peak of the band-passed uncompensated scalar over it (nT).
    pub before_nt: f64,
    /// The same of the compensated scalar (nT).
    pub after_nt: f64,
    /// Whether it is the one its slot counts (the largest swing so far).
    pub counted: bool,
}

/// One sample of the flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxSample {
    /// Time (s).
    pub time_s: f64,
    /// Roll, pitch, yaw (deg).
    pub attitude_deg: [f64; 3],
    /// The uncompensated scalar (nT).
    pub raw_nt: f64,
    /// The compensated scalar (nT).
    pub compensated_nt: f64,
}

/// The box scored as it is flown (see the module's documentation).
#[derive(Debug, Clone)]
pub struct LiveBox {
    settings: LiveBoxSettings,
    fs_hz: f64,
    window: VecDeque<BoxSample>,
    since_search: usize,
    flown: Vec<FlownManeuver>,
}

impl LiveBox {
    /// A live box for samples at `fs_hz` (Hz).
    pub fn new(fs_hz: f64, settings: LiveBoxSettings) -> Self {
        Self {
            settings,
            fs_hz,
            window: VecDeque::new(),
            since_search: 0,
            flown: Vec::new(),
        }
    }

    /// Adds a sample; returns how many maneuvers were newly scored.
    pub fn push(&mut self, sample: BoxSample) -> usize {
        let capacity = (self.settings.window_s * self.fs_hz).ceil().max(1.0) as usize;
        if self.window.len() == capacity {
            self.window.pop_front();
        }
        self.window.push_back(sample);
        self.since_search += 1;
        match self.since_search as f64 >= self.settings.every_s * self.fs_hz {
            true => self.search(self.settings.settle_s),
            false => 0,
        }
    }

    /// At the end of the flight: scores what has ended, however recently.
    pub fn finish(&mut self) -> usize {
        self.search(0.0)
    }

    /// While the flight pauses: scores what has ended by now, however recently; a maneuver
    /// that then goes on is scored again, whole, when it ends.
    pub fn score_now(&mut self) -> usize {
        self.search(0.0)
    }

    /// Every maneuver scored so far, in the order found.
    pub fn flown(&self) -> &[FlownManeuver] {
        &self.flown
    }

    /// The figure of merit (nT) of the counted maneuvers so far, before and after
    /// compensation; `None` before the first.
    pub fn fom_nt(&self) -> Option<(f64, f64)> {
        let counted = self.flown.iter().filter(|m| m.counted);
        counted.fold(None, |sum: Option<(f64, f64)>, m| {
            let (b, a) = sum.unwrap_or((0.0, 0.0));
            Some((
                b + finite_or_zero(m.before_nt),
                a + finite_or_zero(m.after_nt),
            ))
        })
    }

    /// The slots (of the box's 12) that hold a counted maneuver.
    pub fn slots_flown(&self) -> usize {
        self.flown.iter().filter(|m| m.counted).count()
    }

    /// Searches the window; scores the maneuvers that ended `settle_s` (s) before its newest
    /// sample and were not scored before.
    fn search(&mut self, settle_s: f64) -> usize {
        self.since_search = 0;
        let Some(newest) = self.window.back().map(|s| s.time_s) else {
            return 0;
        };
        let column = |f: fn(&BoxSample) -> f64| -> Vec<f64> { self.window.iter().map(f).collect() };
        let tt = column(|s| s.time_s);
        let [roll, pitch, yaw] = [0, 1, 2].map(|k| {
            let values: Vec<f64> = self.window.iter().map(|s| s.attitude_deg[k]).collect();
            values
        });
        let found = detect_maneuvers(&tt, &roll, &pitch, &yaw, &self.settings.maneuvers);
        let ended: Vec<Maneuver> = (found.into_iter())
            .filter(|m| m.end_tt <= newest - settle_s && self.is_new(m))
            .collect();
        if ended.is_empty() {
            return 0;
        }
        let filtered = |f: fn(&BoxSample) -> f64| {
            bandpassed(&column(f), Some(&tt), self.fs_hz, &self.settings.fom).ok()
        };
        let (Some(before), Some(after)) = (filtered(|s| s.raw_nt), filtered(|s| s.compensated_nt))
        else {
            return 0;
        };
        let count = ended.len();
        for m in ended {
            let flown = FlownManeuver {
                before_nt: peak_to_peak(&before[m.range()]),
                after_nt: peak_to_peak(&after[m.range()]),
                counted: false,
                maneuver: m,
            };
            self.keep(flown);
        }
        count
    }

    /// The scored maneuver `m` is (found again in a later window, perhaps cut at the window's
    /// edge): the same kind, over an overlapping time.
    fn scored(&self, m: &Maneuver) -> Option<usize> {
        self.flown.iter().position(|f| {
            let f = &f.maneuver;
            f.kind == m.kind && f.start_tt < m.end_tt && m.start_tt < f.end_tt
        })
    }

    /// Whether `m` is new, or a scored one that has since gone on (scored at a pause).
    fn is_new(&self, m: &Maneuver) -> bool {
        match self.scored(m) {
            None => true,
            Some(k) => {
                let scored = &self.flown[k].maneuver;
                let longer = m.end_tt - m.start_tt > scored.end_tt - scored.start_tt + m.period_s;
                m.end_tt > scored.end_tt + 0.5 * m.period_s || longer
            }
        }
    }

    /// Adds `flown` (replacing its earlier, shorter self) and counts, slot by slot, the
    /// largest swing, the earliest on a tie (the batch's rule).
    fn keep(&mut self, flown: FlownManeuver) {
        if let Some(k) = self.scored(&flown.maneuver) {
            self.flown.remove(k);
        }
        self.flown.push(flown);
        self.flown
            .sort_by(|a, b| a.maneuver.start_tt.total_cmp(&b.maneuver.start_tt));
        let slots: Vec<Option<Slot>> = self.flown.iter().map(|f| Slot::of(&f.maneuver)).collect();
        for k in 0..self.flown.len() {
            let rivals =
                (0..self.flown.len()).filter(|&j| slots[j].is_some() && slots[j] == slots[k]);
            let best = rivals.reduce(|best, j| {
                match self.flown[j].maneuver.amplitude_deg > self.flown[best].maneuver.amplitude_deg
                {
                    true => j,
                    false => best,
                }
            });
            self.flown[k].counted = best == Some(k);
        }
    }
}

fn finite_or_zero(v: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::plan::BoxPlan;
    use crate::flight::sim::{simulate, Installation, Scenario};
    use crate::maneuvers::fom::fom;

    /// A simulated box, its scalar as "raw" and the scalar less the true aircraft field as
    /// "compensated", scored live and in batch.
    /// With `pauses`, the stream pauses every 7 s of flight (as a pipe fed in bursts does):
    /// maneuvers are scored at each pause, and again whole when they go on.
    fn scored(plan: BoxPlan, fs_hz: f64, seed: u64, pauses: bool) {
        let mut scenario = Scenario::new(Installation::Cabin.aircraft(), seed);
        scenario.fs_hz = fs_hz;
        let f = simulate(&plan.build(), &scenario).unwrap();
        let compensated: Vec<f64> = (f.scalar.iter().zip(&f.interference_nt))
            .map(|(s, a)| s - a)
            .collect();
        let mut live = LiveBox::new(fs_hz, LiveBoxSettings::default());
        for (k, &compensated_nt) in compensated.iter().enumerate() {
            live.push(BoxSample {
                time_s: f.tt[k],
                attitude_deg: [f.roll_deg[k], f.pitch_deg[k], f.yaw_deg[k]],
                raw_nt: f.scalar[k],
                compensated_nt,
            });
            if pauses && k % (7.0 * fs_hz) as usize == 0 {
                live.score_now();
            }
        }
        live.finish();
        let settings = LiveBoxSettings::default();
        let found = detect_maneuvers(
            &f.tt,
            &f.roll_deg,
            &f.pitch_deg,
            &f.yaw_deg,
            &settings.maneuvers,
        );
        let batch = |x: &[f64]| fom(x, Some(&f.tt), &found, fs_hz, &settings.fom).unwrap();
        let (before, after) = (batch(&f.scalar), batch(&compensated));
        // The same maneuvers, slot by slot.
        let slots = |kinds: Vec<Option<Slot>>| {
            let mut s: Vec<(u16, usize)> = kinds
                .into_iter()
                .flatten()
                .map(|s| (s.heading_deg, s.kind as usize))
                .collect();
            s.sort();
            s
        };
        let batch_slots = slots(before.counted().map(|m| Slot::of(&m.maneuver)).collect());
        let live_slots = slots(
            (live.flown().iter().filter(|m| m.counted))
                .map(|m| Slot::of(&m.maneuver))
                .collect(),
        );
        assert_eq!(live_slots, batch_slots);
        // Each maneuver once, however many windows saw it.
        assert_eq!(live.flown().len(), found.len(), "{:?}", live.flown());
        assert_eq!(live.slots_flown(), 12);
        let (live_before, live_after) = live.fom_nt().unwrap();
        let close = |live: f64, batch: f64| (live / batch - 1.0).abs();
        println!(
            "fs {fs_hz} Hz: FOM before live {live_before:.3} batch {:.3} nT, after live \
             {live_after:.4} batch {:.4} nT",
            before.fom_nt, after.fom_nt
        );
        assert!(
            close(live_before, before.fom_nt) < 0.02,
            "{live_before} {}",
            before.fom_nt
        );
        assert!(
            close(live_after, after.fom_nt) < 0.10,
            "{live_after} {}",
            after.fom_nt
        );
    }

    #[test]
    fn the_live_box_finds_the_batch_maneuvers_and_its_fom() {
        scored(BoxPlan::default(), 10.0, 1, false);
        scored(BoxPlan::default(), 20.0, 7, false);
        scored(BoxPlan::default(), 10.0, 3, true);
    }

    #[test]
    fn nothing_is_scored_before_a_maneuver_has_settled() {
        let mut live = LiveBox::new(10.0, LiveBoxSettings::default());
        for k in 0..600 {
            let t = k as f64 / 10.0;
            let roll = 10.0 * (2.0 * std::f64::consts::PI * t / 5.0).sin();
            live.push(BoxSample {
                time_s: t,
                attitude_deg: [roll, 0.0, 0.0],
                raw_nt: 50_000.0 + roll,
                compensated_nt: 50_000.0,
            });
        }
        // Still rolling at the newest sample: nothing has ended.
        assert_eq!(live.fom_nt(), None);
        assert!(live.flown().is_empty());
    }
}
