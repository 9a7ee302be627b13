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
    /// Of them, the failures of a sliding joint's ζ equation with its contact point on a
    /// node, and the last one's explanation.
    on_node: Option<(usize, String)>,
}

impl Simulation {
    /// Notes a failed step that will be retried shorter.
    pub(super) fn note_retried_failure(&mut self, failure: &StepFailure) {
        let Some(row) = failure.row else {
            return;
        };
        let entry = self.failures.rows.entry(row).or_default();
        entry.count += 1;
        if let Some((_, hint)) = self.system.node_kink_hint(row, &self.state) {
            let hits = entry.on_node.as_ref().map_or(0, |(n, _)| *n);
            entry.on_node = Some((hits + 1, hint));
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
            if let Some((hits, hint)) = f.on_node.as_ref().filter(|(h, _)| 2 * h >= f.count) {
                text += &format!(". In {hits} of them {hint}");
            }
            out.push(text);
        }
        out
    }
}
