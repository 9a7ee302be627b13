//! Times in messages.

use std::fmt;

/// A time (s) as a message shows it: six decimals from a millisecond up (`0.300000`), four
/// significant digits below (`1.8172e-6`), so that a microstructure's run does not read
/// `t = 0.000002 s` wherever it stopped.
pub struct Seconds(pub f64);

impl fmt::Display for Seconds {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = self.0;
        if t == 0.0 || t.abs() >= 1e-3 || !t.is_finite() {
            write!(f, "{t:.6}")
        } else {
            write!(f, "{t:.4e}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Seconds;

    #[test]
    fn short_times_keep_their_digits() {
        let shown = |t: f64| Seconds(t).to_string();
        assert_eq!(shown(0.3), "0.300000");
        assert_eq!(shown(12.5), "12.500000");
        assert_eq!(shown(0.0), "0.000000");
        assert_eq!(shown(1.8171728e-6), "1.8172e-6");
        assert_eq!(shown(-2.5e-4), "-2.5000e-4");
    }
}
