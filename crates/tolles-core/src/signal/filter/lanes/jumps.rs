//! [`Jumps`](super::Jumps): a filter run forward to chosen samples of many signals at once,
//! block by block of [`LANES`](super::LANES) signals.

use super::*;

/// What [`Jumps`] holds for one block of up to [`LANES`] signals.
pub(super) struct JumpBlock {
    /// The block's signals (their indices).
    signals: Range<usize>,
    ws: Workspace<LANES>,
    /// Each signal's forward pass over the kept samples, once the first is reached.
    forward: Vec<Forward<JUMP_DELAYS>>,
    /// The samples from the last kept one to the end, interleaved.
    tail: Vec<[f64; LANES]>,
}

impl Jumps {
    /// The jumps of `filter` through `count` signals of `n` samples to the samples `at`
    /// (ascending, below `n`), at `ends`; `None` unless the filter has [`JUMP_DELAYS`] delays
    /// and `at` are evenly spaced at a stride worth jumping ([`Jump::between`]).
    pub(crate) fn new(
        filter: &Butterworth,
        at: &[usize],
        ends: Ends,
        count: usize,
        n: usize,
    ) -> Option<Self> {
        if 2 * filter.sections().len() != JUMP_DELAYS {
            return None;
        }
        let jump = Jump::between(filter, at)?;
        let last = at[at.len() - 1];
        assert!(
            last < n && n > filter.padlen(),
            "kept samples within longer signals"
        );
        let blocks = lane_blocks(count)
            .map(|signals| JumpBlock {
                signals,
                ws: Workspace::new(filter),
                forward: Vec::new(),
                tail: vec![[0.0; LANES]; n - last],
            })
            .collect();
        Some(Self {
            weights: jump.weights(),
            jump,
            at: at.to_vec(),
            ends,
            n,
            taken: 0,
            blocks,
        })
    }

    /// [`Jumps::advance_with`] in the widest kernels the processor has.
    pub(crate) fn advance(&mut self, signals: &[&[f64]], upto: usize) {
        (best().jumps_advance)(self, signals, upto)
    }

    /// [`Jumps::finish_inline`] in the widest kernels the processor has.
    pub(crate) fn finish(self, signals: &[&[f64]]) -> Vec<Vec<f64>> {
        (best().jumps_finish)(self, signals)
    }

    /// Samples before the newest that [`Jumps::advance_with`] may read: the signals must still
    /// hold them.
    pub(crate) fn lookback(&self) -> usize {
        self.jump.stride().max(self.blocks[0].ws.pad.len() + 1)
    }

    /// Takes the samples from the last taken up to `upto` (exclusive) of `signals`; it reads
    /// no sample more than [`Jumps::lookback`] before the first of them.
    #[inline(always)]
    pub(super) fn advance_with(
        &mut self,
        transpose: impl Transpose,
        signals: &[&[f64]],
        upto: usize,
    ) {
        let (from, upto) = (self.taken, upto.min(self.n));
        if upto <= from {
            return;
        }
        let (first, last) = (self.at[0], self.at[self.at.len() - 1]);
        for b in &mut self.blocks {
            let x = &signals[b.signals.clone()];
            if from == 0 {
                if x.len() < LANES {
                    b.ws.pad.fill([0.0; LANES]);
                }
                b.ws.start_forward_at(x, self.ends.start);
            }
            let mut start = from;
            while start < first.min(upto) {
                let tile = &mut b.ws.tile[..TILE.min(first.min(upto) - start)];
                gather(transpose, x, start, tile);
                run_two(&mut b.ws.sections, tile, false);
                start += tile.len();
            }
            if from <= first && first < upto {
                for l in 0..x.len() {
                    let delays = delays_of(&b.ws.sections, l);
                    b.forward.push(Forward::new(self.at.len(), delays));
                }
            }
            if upto > first {
                for (f, x) in b.forward.iter_mut().zip(x) {
                    self.jump.forward_until(&self.weights, f, x, &self.at, upto);
                }
            }
            let tail_from = from.max(last);
            if upto > tail_from {
                let part = &mut b.tail[tail_from - last..upto - last];
                gather(transpose, x, tail_from, part);
            }
        }
        self.taken = upto;
    }

    /// The filtered values at the kept samples, one vector per signal, once every sample is
    /// taken; `signals` must still hold their last [`Jumps::lookback`] samples.
    ///
    /// # Panics
    /// If some samples are not taken yet: a programming error of the caller.
    ///
    /// It moves no samples between signals and tiles, so unlike [`Jumps::advance_with`] it
    /// takes no [`Transpose`]; inline, it is compiled into each kernel's instruction set.
    #[inline(always)]
    pub(super) fn finish_inline(mut self, signals: &[&[f64]]) -> Vec<Vec<f64>> {
        assert_eq!(
            self.taken, self.n,
            "every sample is taken before the jumps finish"
        );
        let kept = self.at.len();
        let mut out = Vec::with_capacity(signals.len());
        for b in &mut self.blocks {
            let x = &signals[b.signals.clone()];
            for (l, f) in b.forward.iter().enumerate() {
                set_delays_of(&mut b.ws.sections, l, &f.current);
            }
            // From the last kept sample to the end: its forward output, then back.
            run_two(&mut b.ws.sections, &mut b.tail, false);
            let end_output = b.tail[b.tail.len() - 1];
            if self.ends.end == End::Padded {
                b.ws.trailing_extension(x);
            }
            b.ws.start_backward_at(self.ends.end, end_output);
            run_two(&mut b.ws.sections, &mut b.tail[1..], true);
            for (l, f) in b.forward.iter().enumerate() {
                let mut o = vec![0.0; kept];
                let before_last = delays_of::<LANES, JUMP_DELAYS>(&b.ws.sections, l);
                o[kept - 1] = self.jump.output(&before_last, b.tail[0][l]);
                self.jump.backward::<JUMP_DELAYS>(f, before_last, &mut o);
                out.push(o);
            }
        }
        out
    }
}
