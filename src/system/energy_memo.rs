//! The kinetic and potential energy of the last state asked about, kept: an accepted step
//! needs its start's energy (the last step's end, unless something changed the state in
//! between) and its end's twice (the books and the energy sensor), and the potential energy
//! sums every Gauss point's strain energy.

use super::System;
use crate::state::State;
use std::cell::RefCell;

/// Remembers `(kinetic, potential)` for one state, compared in full (bit for bit up to
/// `==`): any change to the state — a projection, a user's edit — is a new state.
#[derive(Debug, Default)]
pub struct EnergyMemo {
    last: RefCell<Option<(State, f64, f64)>>,
}

impl EnergyMemo {
    /// Kinetic and potential energy of `state` in `sys` (J).
    pub fn energies(&self, sys: &System, state: &State) -> (f64, f64) {
        if let Some((s, kinetic, potential)) = self.last.borrow().as_ref() {
            if s == state {
                return (*kinetic, *potential);
            }
        }
        let (kinetic, potential) = (sys.kinetic_energy(state), sys.potential_energy(state));
        let mut last = self.last.borrow_mut();
        match last.as_mut() {
            // Reuses the kept state's buffers: no allocation per step.
            Some(kept) => {
                kept.0.copy_from(state);
                (kept.1, kept.2) = (kinetic, potential);
            }
            None => *last = Some((state.clone(), kinetic, potential)),
        }
        (kinetic, potential)
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
        let direct = |s: &State| (sys.kinetic_energy(s), sys.potential_energy(s));
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
}
