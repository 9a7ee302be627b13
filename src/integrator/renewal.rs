//! When modified Newton replaces factors that still converge: the optimal-replacement
//! (renewal) rule.
//!
//! Kept factors age: the tangent they were computed from drifts away, and each step needs a
//! few more iterations than the last (a four-bar linkage at 1 ms: 3, 3, 4, 4, 4, 5, 5, 6, 6,
//! 7 …). Fresh factors cost a tangent assembly and an LU — `F` iterations' worth — and bring
//! the count back down. The cost per step of factors replaced after `n` steps is
//! `(F + Σ_{k≤n} iterations_k) / n`, and with counts that grow it is least when they are
//! replaced as soon as the next step would cost more than that mean so far (the classic
//! replacement rule for equipment whose running cost grows with age). The next step is
//! expected to need as many iterations as the last two did: counts are integers that
//! fluctuate by one (a beam pendulum at 1 ms: 3 iterations, an odd 4 every few hundred
//! steps), and one step above the mean is noise, not age — fresh factors would not bring
//! those 3s any lower.
//!
//! The rate test inside a step (`Integrator::contraction_too_slow`) still replaces factors
//! that contract too slowly for the step at hand; this rule replaces, at a step's start,
//! factors that converge but no longer pay.

/// The steps and iterations the factors in hand have served.
#[derive(Clone, Copy, Debug, Default)]
pub struct Renewal {
    steps: usize,
    iterations: usize,
    /// The last two steps' counts (the earlier first).
    last: [usize; 2],
}

impl Renewal {
    /// Fresh factors: their count starts (the step they were computed in counts whole).
    pub fn restart(&mut self) {
        self.steps = 0;
        self.iterations = 0;
    }

    /// The steps served.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// A step converged with the factors in hand after `iterations` Newton iterations.
    pub fn record(&mut self, iterations: usize) {
        self.steps += 1;
        self.iterations += iterations;
        self.last = [self.last[1], iterations];
    }

    /// Whether the factors in hand should be replaced before the next step, fresh ones
    /// costing `refresh_cost` iterations: the last two steps' counts both above the mean cost
    /// per step so far. Three steps at least: the first (with its refresh) says nothing about
    /// aging.
    pub fn due(&self, refresh_cost: f64) -> bool {
        let mean_total = refresh_cost + self.iterations as f64;
        self.steps >= 3
            && self
                .last
                .iter()
                .all(|&c| (c * self.steps) as f64 > mean_total)
    }
}

/// The cost of fresh factors in Newton iterations (a residual assembly and a solve each), for
/// a Newton matrix of `nnz` entries over `n` unknowns: `nnz / n`, the entries per row. The
/// tangent of a kernel costs about one residual per unknown its rows couple to (a dual
/// number per direction, or as many hand-derived columns), and an LU about as many solves as
/// its factors have entries per row; both scale with the entries per row. Measured (callgrind
/// instructions, tangent and LU against a residual-only iteration): 12-element beam pendulum
/// ED ~53 (58 entries per row), EP ~24 (29); the optimum is flat (half or twice the cost moves
/// the four-bar's and the beam pendulum's totals by under 3 %).
///
/// ED's decoupled system assembles about half the exact tangent's entries (its j-rows' motion
/// columns and the constraint columns), and factors a complex matrix of half the size: half
/// the cost (`decoupled`).
pub fn refresh_cost(nnz: usize, n: usize, decoupled: bool) -> f64 {
    let per_row = nnz as f64 / n.max(1) as f64;
    if decoupled {
        0.5 * per_row
    } else {
        per_row
    }
}

/// ED: fresh factorizations of the kind in hand (exact or decoupled) in a row, and when the
/// other kind is tried again so that the choice between them does not go stale. Each retrial
/// costs a factorization of the kind judged dearer and its dearer iterations (a free collar
/// at 5 ms, where decoupled factors win: a retrial every 16 refreshes cost 9 % of the run),
/// so each retrial doubles the wait before the next; a retried kind that goes on being
/// chosen has won (the model's regime changed), and the waits start over.
#[derive(Clone, Copy, Debug)]
pub struct KindStreak {
    /// The kind of the last fresh factors (decoupled or exact), if any were taken. Kept here,
    /// not read from the factors in hand: a new pattern (a sliding contact's window moved)
    /// drops those without changing the kind the run is choosing.
    decoupled: Option<bool>,
    streak: usize,
    retrial_after: usize,
    /// Whether the kind in hand was taken by a retrial.
    retrying: bool,
}

/// Refreshes of one kind before the other is first tried again, and the longest wait.
const FIRST_RETRIAL_AFTER: usize = 16;
const LONGEST_RETRIAL_AFTER: usize = 512;
/// Refreshes in a row of a retried kind after which it has won.
const RETRIAL_WON: usize = 4;

impl Default for KindStreak {
    fn default() -> Self {
        KindStreak {
            decoupled: None,
            streak: 0,
            retrial_after: FIRST_RETRIAL_AFTER,
            retrying: false,
        }
    }
}

impl KindStreak {
    /// Whether the last fresh factors were the decoupled system's.
    pub fn last_decoupled(&self) -> bool {
        self.decoupled == Some(true)
    }

    /// Whether the next fresh factors should be of the other kind, to try it again.
    pub fn retrial_due(&self) -> bool {
        self.streak >= self.retrial_after
    }

    /// Fresh factors were taken: the decoupled system's, or the exact matrix's.
    pub fn record(&mut self, decoupled: bool) {
        let switched = self.decoupled.is_some_and(|d| d != decoupled);
        self.decoupled = Some(decoupled);
        if !switched {
            self.streak += 1;
            if self.retrying && self.streak >= RETRIAL_WON {
                self.retrying = false;
                self.retrial_after = FIRST_RETRIAL_AFTER;
            }
            return;
        }
        self.retrying = self.retrial_due();
        if self.retrying {
            self.retrial_after = (2 * self.retrial_after).min(LONGEST_RETRIAL_AFTER);
        }
        self.streak = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Iterations growing by one every four steps, fresh factors worth 10 iterations: the
    /// mean cost per step `(10 + Σ)/n` is least after 8 steps (38/8 = 4.75). The rule sees the
    /// growth two steps late (it waits for a second count above the mean) and replaces them
    /// after the 10th, at 48/10 = 4.8; never, or after every step, would cost 5+ and 13.
    #[test]
    fn replaces_factors_near_the_least_mean_cost_per_step() {
        let counts = [3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 6, 6, 6, 6];
        let mut r = Renewal::default();
        let mut replaced_after = None;
        for (k, &c) in counts.iter().enumerate() {
            r.record(c);
            if r.due(10.0) {
                replaced_after = Some(k + 1);
                break;
            }
        }
        let mean = |n: usize| (10 + counts[..n].iter().sum::<usize>()) as f64 / n as f64;
        let best = (1..=counts.len())
            .min_by(|&a, &b| mean(a).total_cmp(&mean(b)))
            .unwrap();
        assert_eq!(best, 8);
        assert_eq!(replaced_after, Some(10));
        assert!(mean(10) <= 1.02 * mean(best));
    }

    /// Counts that do not grow never pay for fresh factors (the beam pendulum's EP factors
    /// serve a whole run), an odd count above the rest is noise, and a restart forgets the
    /// steps served.
    #[test]
    fn factors_that_do_not_age_are_kept() {
        let mut r = Renewal::default();
        for k in 0..1000 {
            r.record(if k % 100 == 99 { 4 } else { 3 });
            assert!(!r.due(1.0), "step {k}");
        }
        r.restart();
        r.record(3);
        r.record(9);
        assert!(
            !r.due(0.0),
            "two steps, one of them the refresh's, say nothing of aging"
        );
        r.record(9);
        assert!(r.due(0.0), "two counts of 9 above the mean 7");
    }

    #[test]
    fn refresh_cost_is_the_entries_per_row() {
        assert_eq!(refresh_cost(26085, 450, false), 26085.0 / 450.0);
        assert_eq!(refresh_cost(900, 30, true), 15.0);
        assert_eq!(refresh_cost(0, 0, false), 0.0);
    }

    /// Retrials that lose come ever more rarely (16, 32, 64 … refreshes apart, at most 512),
    /// whatever other switches happen between them (a step the decoupled factors missed
    /// takes exact ones); a retried kind that goes on being chosen starts the waits over.
    #[test]
    fn retrials_that_lose_back_off_and_one_that_wins_resets_them() {
        let mut k = KindStreak::default();
        let mut retrials = Vec::new();
        for refresh in 0..2000 {
            if k.retrial_due() {
                retrials.push(refresh);
                k.record(false); // the exact matrix retried
                k.record(true); // it lost: back to decoupled factors at once
            } else if refresh == 30 {
                k.record(false); // a missed step's exact factors: not a retrial
            } else {
                k.record(true);
            }
        }
        let gaps: Vec<usize> = retrials.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!(retrials[0], 16);
        assert_eq!(&gaps[..5], &[48, 65, 129, 257, 513], "{retrials:?}");
        assert!(gaps[5..].iter().all(|&g| g == 513), "{gaps:?}");
        // A retrial that wins: the exact matrix chosen 4 more times; 16 in a row to the next.
        while !k.retrial_due() {
            k.record(true);
        }
        (0..5).for_each(|_| k.record(false));
        assert!(!k.retrial_due());
        (0..11).for_each(|_| k.record(false));
        assert!(!k.retrial_due());
        k.record(false);
        assert!(k.retrial_due());
    }
}
