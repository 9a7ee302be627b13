//! Diagnostics of the model's functions of time (drives and load scales): a run that meets
//! one that is undefined (`sqrt(0.3 - t)` after 0.3 s, a division by zero) must say so, not
//! blame the step size or a joint row.

use super::System;

impl System {
    /// The first drive or load scale whose value or rate is not finite at `t_i` or `t_f`,
    /// described for the user; `None` when all are defined over the step.
    pub fn undefined_time_function(&self, t_i: f64, t_f: f64) -> Option<String> {
        let bad = |v: f64, r: f64| !(v.is_finite() && r.is_finite());
        for d in &self.drives {
            for t in [t_i, t_f] {
                let f = d.function.jet(t);
                let (v, r) = (f.v, f.d);
                if bad(v, r) {
                    let name = &self.row_names[d.row].0;
                    return Some(undefined("the drive", name, t, v, r));
                }
            }
        }
        for (name, f) in &self.load_scales {
            for t in [t_i, t_f] {
                let (v, r) = (f.value(t), f.rate(t));
                if bad(v, r) {
                    return Some(undefined("the scale of load", name, t, v, r));
                }
            }
        }
        None
    }
}

fn undefined(what: &str, name: &str, t: f64, value: f64, rate: f64) -> String {
    format!(
        "{what} `{name}` is not defined at t = {t:.6} s (value {value}, rate {rate}): a function of time must be finite over the whole run (check its expression or table there, or end the run before t = {t:.6} s)"
    )
}
