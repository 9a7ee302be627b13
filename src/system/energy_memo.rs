//! The energies of the last two states asked about, kept: an adaptive step's error indicator
//! reads its end's motion energies, and the accepted step its start's energy (the last
//! step's end, unless something changed the state in between) and its end's (the books, the
//! energy scales, the energy sensor), and the strain energy sums every Gauss point.

use super::System;
use crate::state::State;
use std::cell::{Cell, RefCell};

/// A state's energy by parts (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energies {
    /// `Σ ½ m v·v` of the nodes' translations.
    pub translational: f64,
    /// `Σ ½ W·J W` of their rotations.
    pub rotational: f64,
    /// Gravity's potential, `−Σ m g·x`.
    pub gravity: f64,
    /// The joints' springs.
    pub springs: f64,
    /// The beams' strain energy.
    pub strain: f64,
}

impl Energies {
    pub fn kinetic(&self) -> f64 {
        self.translational + self.rotational
    }

    /// Gravity's, the springs' and the strain energy.
    pub fn potential(&self) -> f64 {
        self.gravity + self.springs + self.strain
    }

    /// The energy that measures a motion's size: kinetic, strain and spring energy (gravity's
    /// potential is left out: its datum is arbitrary).
    pub fn motion(&self) -> f64 {
        self.kinetic() + self.stored()
    }

    /// The motion energies the step controller judges errors against: total, and the
    /// translational and rotational kinetic energies each with the stored (strain and spring)
    /// energy.
    pub fn motion_parts(&self) -> [f64; 3] {
        let stored = self.stored();
        [
            self.motion(),
            self.translational + stored,
            self.rotational + stored,
        ]
    }

    fn stored(&self) -> f64 {
        self.springs + self.strain
    }
}

/// Remembers [`Energies`] for two states, each compared in full (bit for bit up to `==`): any
/// change to a state — a projection, a user's edit — is a new state.
#[derive(Debug, Default)]
pub struct EnergyMemo {
    kept: RefCell<[Option<(State, Energies)>; 2]>,
    /// The slot asked about last; a new state replaces the other one.
    newest: Cell<usize>,
}

impl EnergyMemo {
    /// The energies of `state` in `sys`.
    pub fn energies(&self, sys: &System, state: &State) -> Energies {
        let found = self.kept.borrow().iter().position(|k| match k {
            Some((s, _)) => s == state,
            None => false,
        });
        if let Some(slot) = found {
            self.newest.set(slot);
            return self.kept.borrow()[slot].as_ref().unwrap().1;
        }
        let energies = sys.energies(state);
        let slot = 1 - self.newest.get();
        self.newest.set(slot);
        match &mut self.kept.borrow_mut()[slot] {
            // Reuses the kept state's buffers: no allocation per step.
            Some(kept) => {
                kept.0.copy_from(state);
                kept.1 = energies;
            }
            empty => *empty = Some((state.clone(), energies)),
        }
        energies
    }
}

impl Clone for EnergyMemo {
    /// A fresh memo: a copy recomputes on first use.
    fn clone(&self) -> Self {
        EnergyMemo::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compile::from_yaml_str;
    use crate::simulation::Simulation;

    #[test]
    fn a_state_changed_in_any_part_is_a_new_state() {
        let yaml = include_str!("../../examples/beam_pendulum.yaml");
        let mut sim = Simulation::new(&from_yaml_str(yaml).unwrap()).unwrap();
        sim.advance_to(0.02).unwrap();
        let sys = &sim.system;
        let direct = |s: &State| sys.energies(s);
        let memo = EnergyMemo::default();
        let mut state = sim.state.clone();
        assert_eq!(memo.energies(sys, &state), direct(&state));
        assert_eq!(memo.energies(sys, &state), direct(&state));
        // A velocity (kinetic energy), a position (gravity's), a Gauss point's triad (strain):
        // each asked about after the memo kept the state before it.
        let changes: [fn(&mut State); 3] = [
            |s| s.nodes[3].v.0[1] += 0.1,
            |s| s.nodes[5].x.0[1] += 1e-3,
            |s| s.history[1] += 1e-4,
        ];
        for change in changes {
            let before = memo.energies(sys, &state);
            change(&mut state);
            let after = memo.energies(sys, &state);
            assert_ne!(after, before);
            assert_eq!(after, direct(&state));
        }
    }

    #[test]
    fn two_states_are_kept_and_a_third_replaces_the_one_asked_about_least_recently() {
        let yaml = include_str!("../../examples/beam_pendulum.yaml");
        let mut sim = Simulation::new(&from_yaml_str(yaml).unwrap()).unwrap();
        let sys = sim.system.clone();
        let a = sim.state.clone();
        sim.advance_to(0.01).unwrap();
        let b = sim.state.clone();
        sim.advance_to(0.02).unwrap();
        let c = sim.state.clone();
        let memo = EnergyMemo::default();
        let kept = |memo: &EnergyMemo| -> Vec<f64> {
            let slots = memo.kept.borrow();
            slots.iter().flatten().map(|(s, _)| s.t).collect()
        };
        memo.energies(&sys, &a);
        memo.energies(&sys, &b);
        memo.energies(&sys, &a); // a is now the newer
        assert_eq!(memo.energies(&sys, &c), sys.energies(&c));
        let mut times = kept(&memo);
        times.sort_by(f64::total_cmp);
        assert_eq!(times, vec![a.t, c.t], "b, asked about least recently, went");
        // Both kept states answer from the memo: equal to a fresh sum.
        assert_eq!(memo.energies(&sys, &a), sys.energies(&a));
        assert_eq!(memo.energies(&sys, &c), sys.energies(&c));
    }
}
