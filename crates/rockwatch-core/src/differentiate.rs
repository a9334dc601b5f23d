//! Differentiation of a sampled signal on a uniform grid, streaming: velocity channels
//! (StationXML input units m/s) turned into acceleration, record by record, with the same
//! result however the stream is cut into records.
//!
//! Scheme (docs/stationxml.md, "Velocity channels"), for samples `x[k]` at spacing `h`:
//! - interior sample (both neighbours on the grid): central difference
//!   `d[k] = (x[k+1] − x[k−1]) / 2h`. For `x = A sin(ωt)` it gives exactly
//!   `A ω cos(ωt) · sin(ωh)/(ωh)`, so the error is at most `A ω (1 − sinc ωh) ≤ A ω (ωh)²/6`;
//!   in general at most `h²/6 · max|x'''|`;
//! - first sample of a contiguous run (start, or after a gap): forward difference
//!   `(x[k+1] − x[k]) / h`; last sample of a run (a gap follows, or the caller gives up
//!   waiting, [`Differentiator::flush`]): backward difference `(x[k] − x[k−1]) / h`. Error at
//!   most `h/2 · max|x''|`;
//! - an isolated sample (no neighbour on either side) has no derivative: nothing is emitted
//!   for it (the caller treats it as missing).
//!
//! Because a sample's central difference needs the next sample, the latest sample of the
//! stream is *held* until its successor arrives (one sample of delay), and continuity across
//! records is kept by the state (`prev`, `held`): records split anywhere give bit-for-bit the
//! same output as one record. Derivatives are returned per sample (`x` units per sample
//! interval); multiply by the rate for per-second units.

/// The streaming differentiator of one channel. Grid indices must increase; a sample at or
/// before one already taken is ignored (overlap, counted by the caller).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Differentiator {
    /// The sample before `held` (index, value), when it is its grid neighbour.
    prev: Option<(i64, f64)>,
    /// The latest sample, waiting for its successor.
    held: Option<(i64, f64)>,
    /// Highest index taken (also after a flush).
    last: Option<i64>,
}

impl Differentiator {
    #[must_use]
    pub fn new() -> Differentiator {
        Differentiator::default()
    }

    /// Takes sample `x` at grid index `k`; calls `out(index, derivative per sample)` for the
    /// sample that became computable (at most two: a held sample closed by a gap, then none;
    /// or the held sample's central/forward difference). Returns false when `k` is not after
    /// the last index taken (ignored).
    pub fn push(&mut self, k: i64, x: f64, out: &mut dyn FnMut(i64, f64)) -> bool {
        if self.last.is_some_and(|l| k <= l) {
            return false;
        }
        match self.held {
            Some((kh, xh)) if k == kh + 1 => {
                let d = match self.prev {
                    Some((kp, xp)) if kp == kh - 1 => 0.5 * (x - xp),
                    _ => x - xh,
                };
                out(kh, d);
                self.prev = Some((kh, xh));
            }
            Some(_) => {
                // A gap: the held sample ends its run.
                self.flush(out);
                self.prev = None;
            }
            None => {
                // After a flush, the flushed sample is still the neighbour of k if adjacent.
                if self.prev.is_some_and(|(kp, _)| kp != k - 1) {
                    self.prev = None;
                }
            }
        }
        self.held = Some((k, x));
        self.last = Some(k);
        true
    }

    /// Gives up waiting for the held sample's successor: emits its backward difference (none
    /// for an isolated sample). A later sample at the next index still sees it as neighbour.
    pub fn flush(&mut self, out: &mut dyn FnMut(i64, f64)) {
        if let Some((kh, xh)) = self.held.take() {
            if let Some((kp, xp)) = self.prev.filter(|(kp, _)| *kp == kh - 1) {
                let _ = kp;
                out(kh, xh - xp);
            }
            self.prev = Some((kh, xh));
        }
    }

    /// The index of the sample held for its successor, if any.
    #[must_use]
    pub fn held_index(&self) -> Option<i64> {
        self.held.map(|(k, _)| k)
    }

    /// Adds `by` to every index kept (the caller's grid origin moved back by `by` samples).
    pub fn shift(&mut self, by: i64) {
        if let Some(p) = &mut self.prev {
            p.0 += by;
        }
        if let Some(h) = &mut self.held {
            h.0 += by;
        }
        if let Some(l) = &mut self.last {
            *l += by;
        }
    }
}

/// Differentiates one contiguous run of samples at `rate_hz` in one go (derivative per
/// second): the scheme of [`Differentiator`], the last sample by backward difference. Empty
/// for fewer than two samples.
#[must_use]
pub fn differentiate(samples: &[f64], rate_hz: f64) -> Vec<f64> {
    let mut d = Differentiator::new();
    let mut out = Vec::with_capacity(samples.len());
    let mut take = |_k: i64, v: f64| out.push(v * rate_hz);
    for (k, &x) in samples.iter().enumerate() {
        d.push(k as i64, x, &mut take);
    }
    d.flush(&mut take);
    if out.len() < samples.len() {
        out.clear();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(chunks: &[(i64, Vec<f64>)], flush: bool) -> Vec<(i64, f64)> {
        let mut d = Differentiator::new();
        let mut out = Vec::new();
        for (k0, xs) in chunks {
            for (i, &x) in xs.iter().enumerate() {
                d.push(k0 + i as i64, x, &mut |k, v| out.push((k, v)));
            }
        }
        if flush {
            d.flush(&mut |k, v| out.push((k, v)));
        }
        out
    }

    #[test]
    fn a_parabola_is_differentiated_exactly_inside_and_to_first_order_at_the_ends() {
        // x = k²: central (k+1)² − (k−1)² over 2 = 2k exactly; forward at 0: 1; backward at 4: 7.
        let xs: Vec<f64> = (0..5).map(|k| f64::from(k * k)).collect();
        let out = run(&[(0, xs)], true);
        assert_eq!(out, vec![(0, 1.0), (1, 2.0), (2, 4.0), (3, 6.0), (4, 7.0)]);
    }

    #[test]
    fn records_cut_anywhere_give_the_same_result_and_gaps_end_runs() {
        let xs: Vec<f64> = (0..40).map(|k| (f64::from(k) * 0.3).sin() * 1e3).collect();
        let whole = run(&[(0, xs.clone())], true);
        for cut in [1, 2, 7, 39] {
            let parts = [(0, xs[..cut].to_vec()), (cut as i64, xs[cut..].to_vec())];
            assert_eq!(run(&parts, true), whole, "cut at {cut}");
        }
        // A gap of two samples after index 9: 9 gets the backward difference, 12 the forward.
        let out = run(&[(0, xs[..10].to_vec()), (12, xs[12..20].to_vec())], true);
        let at = |k| out.iter().find(|(i, _)| *i == k).map(|(_, v)| *v);
        assert_eq!(at(9), Some(xs[9] - xs[8]));
        assert_eq!(at(12), Some(xs[13] - xs[12]));
        assert_eq!(at(10), None);
        // Overlapping samples are ignored; an isolated sample gives nothing.
        let mut d = Differentiator::new();
        let mut n = 0;
        assert!(d.push(5, 1.0, &mut |_, _| n += 1));
        assert!(!d.push(5, 2.0, &mut |_, _| n += 1));
        d.flush(&mut |_, _| n += 1);
        assert_eq!(n, 0);
        // After a flush (gave up waiting), the next adjacent sample still has its neighbour.
        let mut out = Vec::new();
        let mut d = Differentiator::new();
        for (k, x) in [(0, 0.0), (1, 1.0)] {
            d.push(k, x, &mut |k, v| out.push((k, v)));
        }
        d.flush(&mut |k, v| out.push((k, v)));
        for (k, x) in [(2, 4.0), (3, 9.0)] {
            d.push(k, x, &mut |k, v| out.push((k, v)));
        }
        assert_eq!(out, vec![(0, 1.0), (1, 1.0), (2, 4.0)]);
    }

    #[test]
    fn shifting_the_grid_keeps_the_run() {
        let mut d = Differentiator::new();
        let mut out = Vec::new();
        d.push(0, 0.0, &mut |k, v| out.push((k, v)));
        d.push(1, 1.0, &mut |k, v| out.push((k, v)));
        d.shift(10);
        d.push(12, 4.0, &mut |k, v| out.push((k, v)));
        // (0 was emitted before the shift.)
        assert_eq!(out, vec![(0, 1.0), (11, 2.0)]);
        assert_eq!(d.held_index(), Some(12));
    }
}
