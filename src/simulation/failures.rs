//! Steps that failed and were retried shorter: counted per equation that did not balance, so
//! that a run which crawls through many retries says where (a run that stops says so in its
//! error already). A free sliding contact resting on a beam node is named
//! ([`crate::joints::sliding::SlidingJoint::node_kink_hint`]).

use super::Simulation;
use crate::integrator::StepFailure;
use std::collections::BTreeMap;

/// Retried failures at one equation below this many are noise, not a pattern worth a warning.
const WORTH_A_WARNING: usize = 10;

/// Per unbalanced equation (row), the retried Newton failures.
#[derive(Clone, Debug, Default)]
pub struct FailureLog {
    rows: BTreeMap<usize, RowFailures>,
}

#[derive(Clone, Debug, Default)]
struct RowFailures {
    count: usize,
    /// A sliding joint whose ζ equation this is, the failures with its contact point on a
    /// node, and that contact point (ζ_i).
    on_node: Option<(usize, usize, f64)>,
}

impl Simulation {
    /// Notes a failed step that will be retried shorter.
    pub(super) fn note_retried_failure(&mut self, failure: &StepFailure) {
        let Some(row) = failure.row else {
            return;
        };
        let layout = self.system.layout;
        let entry = self.failures.rows.entry(row).or_default();
        entry.count += 1;
        for (j, sl) in self.system.joints.iter().enumerate() {
            let Some(sl) = sl.as_sliding() else {
                continue;
            };
            let zeta_row = row == layout.coord_delta(sl.coord)
                || (layout.ed() && row == layout.coord_jump(sl.coord));
            let zeta = self.state.coords[sl.coord];
            if zeta_row && sl.node_kink_hint(zeta).is_some() {
                let hits = entry.on_node.map_or(0, |(_, n, _)| n);
                entry.on_node = Some((j, hits + 1, zeta));
            }
        }
    }

    /// The warnings of the run so far: those of its start, then one per equation at which
    /// at least [`WORTH_A_WARNING`] steps failed and were retried shorter.
    pub fn run_warnings(&self) -> Vec<String> {
        let mut out = self.warnings.clone();
        for (&row, f) in &self.failures.rows {
            if f.count < WORTH_A_WARNING {
                continue;
            }
            let mut text = format!(
                "{} steps did not converge and were retried shorter (the steps went down to {:.2e} s); the equation left unbalanced: {}",
                f.count,
                self.stats.dt_smallest,
                self.system.describe_row(row)
            );
            let on_node = f.on_node.filter(|&(_, hits, _)| 2 * hits >= f.count);
            if let Some((j, hits, zeta)) = on_node {
                let sl = self.system.joints[j].as_sliding();
                if let Some(hint) = sl.and_then(|sl| sl.node_kink_hint(zeta)) {
                    text += &format!(". In {hits} of them {hint}");
                }
            }
            out.push(text);
        }
        out
    }
}
