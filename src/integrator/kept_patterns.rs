//! Newton matrices kept per placement of the sliding contacts' windows.
//!
//! A sliding joint's window of beam nodes moves when its contact point crosses into another
//! element, and the Newton matrix's pattern changes with it: a new pattern, ordering, block
//! positions, decoupled system and block factors, and a first factorization that chooses its
//! pivots. A contact that oscillates (the beam slider's driven collar, a collar bouncing
//! between end stops) brings its windows back again and again; the patterns built for
//! them are kept here, a few, and taken back whole — their ordering, and pivots that a
//! refactorization tries first.
//!
//! A kept pattern's matrices carry no counts: they were handed to the matrix that took over
//! (the integrator's totals stay those of the work done).

use super::contact_border::ContactBorder;
use super::ed_decoupled::DecoupledSystem;
use super::positions::KernelPositions;
use super::structure::BlockStructure;
use crate::system::paired::PairedLu;
use crate::system::sparse::NewtonMatrix;
use crate::system::System;

/// The Newton-matrix entries the kept patterns may hold together (the one left longest ago
/// goes first): what four of the largest kept matrices held when at most four were kept, so
/// the memory bound is unchanged, while a contact sweeping across more windows keeps them
/// all — the beam slider's collar sweeps five, which four kept sets could not hold in a
/// forward-and-back sweep (two rebuilt per sweep: 3 % of its runs at 5 ms, both schemes).
/// The beam slider's ED matrix (35 000 entries) then keeps 29, the VDTR's (147 000) 7.
const KEPT_ENTRIES: usize = 1 << 20;

/// Matrices with more entries than this are not kept: a kept set holds the real, complex and
/// block factors of its pattern. 2¹⁸ entries is 7× the beam slider's ED matrix (35 000) and
/// 1.8× the VDTR's (147 000); larger models keep their memory.
const KEEP_BELOW_ENTRIES: usize = 1 << 18;

/// Each sliding joint's window (element range), in joint order: what a pattern depends on
/// beyond the system itself.
pub type Placement = Vec<(usize, usize)>;

pub fn placement(sys: &System) -> Placement {
    sys.joints
        .iter()
        .filter_map(|j| j.as_sliding())
        .map(|s| s.window())
        .collect()
}

/// Everything an integrator builds for one pattern.
pub struct PatternSet {
    pub placement: Placement,
    pub matrix: NewtonMatrix,
    pub pos: KernelPositions,
    pub structure: BlockStructure,
    pub decoupled: Option<DecoupledSystem>,
    pub paired: Option<PairedLu>,
    pub contact_border: Option<ContactBorder>,
    pub decoupled_border: Option<ContactBorder<faer::c64>>,
}

/// The patterns left, most recently left last, and the entries their matrices may hold
/// together.
pub struct KeptPatterns {
    sets: Vec<PatternSet>,
    budget: usize,
}

impl Default for KeptPatterns {
    fn default() -> Self {
        KeptPatterns {
            sets: Vec::new(),
            budget: KEPT_ENTRIES,
        }
    }
}

impl KeptPatterns {
    /// The set kept for `placement`, if any (removed from the kept ones).
    pub fn take(&mut self, placement: &Placement) -> Option<PatternSet> {
        let at = self.sets.iter().position(|s| s.placement == *placement)?;
        Some(self.sets.remove(at))
    }

    /// Keeps a set just left (unless its matrix is too large) in place of any kept for the
    /// same placement; those left longest ago go while the kept matrices hold more entries
    /// than the budget ([`KEPT_ENTRIES`]).
    pub fn keep(&mut self, set: PatternSet) {
        if set.matrix.nnz() > KEEP_BELOW_ENTRIES {
            return;
        }
        self.sets.retain(|s| s.placement != set.placement);
        self.sets.push(set);
        let mut held: usize = self.sets.iter().map(|s| s.matrix.nnz()).sum();
        while held > self.budget {
            held -= self.sets.remove(0).matrix.nnz();
        }
    }

    #[cfg(test)]
    fn placements(&self) -> Vec<&Placement> {
        self.sets.iter().map(|s| &s.placement).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::super::Integrator;
    use crate::joints::Joint;
    use crate::math::layout::Scheme;
    use crate::system::System;

    fn place_windows(sys: &mut System, zeta: Option<f64>) {
        let coords = sys.initial.coords.clone();
        for j in &mut sys.joints {
            if let Joint::Sliding(s) = j {
                s.place_window(zeta.unwrap_or(coords[s.coord]));
            }
        }
    }

    /// A sliding window that moves away and comes back takes back the pattern built for it
    /// — the same pattern, with nothing ordered again — without counting its factorizations
    /// twice, and steps on as an integrator that never left it: to 1e-9 m, Newton's
    /// tolerance with a margin (the pattern taken back starts from fresh factors, the other
    /// from kept ones), under both schemes.
    #[test]
    fn a_returning_window_takes_back_its_pattern() {
        let path = format!("{}/examples/free_collar.yaml", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(path).unwrap();
        let model = crate::compile::from_yaml_str(&text).unwrap();
        let h = model.simulation.dt;
        for scheme in [Scheme::Ep, Scheme::Ed] {
            let mut sys = crate::compile::compile(&model, scheme).unwrap();
            let mut moved = Integrator::new(&sys, &model.simulation);
            let mut stayed = Integrator::new(&sys, &model.simulation);
            let (mut a, mut b) = (sys.initial.clone(), sys.initial.clone());
            for _ in 0..5 {
                a = moved.step(&sys, &a, h).unwrap().0;
                b = stayed.step(&sys, &b, h).unwrap().0;
            }
            let counts = |i: &Integrator| {
                [
                    i.factorizations(),
                    i.pivoting_factorizations(),
                    i.matrix.orderings,
                ]
            };
            let before = counts(&moved);
            let pattern = {
                let (c, r) = moved.matrix.pattern();
                (c.to_vec(), r.to_vec())
            };
            place_windows(&mut sys, Some(1.5));
            moved.rebuild_pattern(&sys, h);
            place_windows(&mut sys, None);
            moved.rebuild_pattern(&sys, h);
            assert_eq!(moved.patterns_taken_back, 1, "{scheme:?}");
            let (c, r) = moved.matrix.pattern();
            assert!(
                c == pattern.0 && r == pattern.1,
                "{scheme:?}: another pattern"
            );
            let [f, p, o] = counts(&moved);
            assert_eq!([f, p], before[..2], "{scheme:?}: counted twice");
            assert_eq!(
                o,
                before[2] + 1,
                "{scheme:?}: only the pattern away ordered"
            );
            for _ in 0..10 {
                a = moved.step(&sys, &a, h).unwrap().0;
                b = stayed.step(&sys, &b, h).unwrap().0;
            }
            for (na, nb) in a.nodes.iter().zip(&b.nodes) {
                assert!((na.x - nb.x).norm() < 1e-9, "{scheme:?}");
            }
        }
    }

    /// One pattern kept per placement other than the one in place — all of them while
    /// their matrices fit the budget, then, with a budget of two such matrices, the two left
    /// most recently, the one left longest ago going first.
    #[test]
    fn one_pattern_is_kept_per_placement_within_the_budget() {
        let (kept, visited) = kept_after_a_sweep(None);
        // More than the four a count of four kept: the budget holds them all.
        assert!(visited.len() > 4, "{visited:?}");
        assert_eq!(kept, visited);
        let (kept, visited) = kept_after_a_sweep(Some(2));
        assert_eq!(kept, visited[visited.len() - 2..]);
    }

    /// The placements kept after a collar's window visited nine others (the budget, if
    /// given, in matrices of the pattern's size), and those left, oldest first.
    fn kept_after_a_sweep(budget: Option<usize>) -> (Vec<super::Placement>, Vec<super::Placement>) {
        // The beam slider: a collar on a 12-element beam, windows of three elements.
        let path = format!(
            "{}/examples/beam_slider/case1.yaml",
            env!("CARGO_MANIFEST_DIR")
        );
        let model = crate::compile::from_yaml_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        let mut sys = crate::compile::compile(&model, Scheme::Ep).unwrap();
        let h = model.simulation.dt;
        let mut integ = Integrator::new(&sys, &model.simulation);
        if let Some(b) = budget {
            // The windows' patterns differ by a few entries (more at the beam's ends): a
            // budget of b matrices and a half holds b of them, not b + 1.
            integ.kept.budget = b * integ.matrix.nnz() + integ.matrix.nnz() / 2;
        }
        let start = super::placement(&sys);
        // Rebuilt for the windows in place: nothing is kept for them.
        integ.rebuild_pattern(&sys, h);
        assert!(integ.kept.placements().is_empty());
        let mut visited = vec![start];
        for zeta in [0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5, 8.5, 3.0] {
            place_windows(&mut sys, Some(zeta));
            let here = super::placement(&sys);
            if here == *visited.last().unwrap() {
                continue;
            }
            integ.rebuild_pattern(&sys, h);
            visited.retain(|p| *p != here);
            visited.push(here);
        }
        // The current placement is not kept.
        let current = visited.pop().unwrap();
        let kept: Vec<_> = integ.kept.placements().into_iter().cloned().collect();
        assert!(!kept.contains(&current));
        (kept, visited)
    }
}
