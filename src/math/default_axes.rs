//! Default axes that complete a triad from one given direction, shared by the beam mesher and
//! the file format's placement of patterned items (which must pick the same axes).

use crate::math::vec3::V3;

/// The default section axis 2 of a beam along `t`: `ẑ × t`, horizontal, so that axis 3
/// (`t × e₂`) lies in the vertical plane through the beam on the +z side — for a horizontal beam
/// it is +z. It turns continuously with the beam's direction (identical blades patterned about
/// z get identical frames); a vertical beam, where `ẑ × t` vanishes, takes +y (the limit of a
/// beam tilted from the vertical towards +x).
pub fn default_e2(t: V3<f64>) -> V3<f64> {
    let h = V3([0.0, 0.0, 1.0]).cross(&t);
    if h.norm() > 1e-6 * t.norm() {
        h
    } else {
        V3([0.0, 1.0, 0.0])
    }
}
