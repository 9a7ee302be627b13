//! Model generators shared by benchmarks and tests (not part of the user API).

/// YAML of a chain of `n` rigid links hanging from the ground on revolute joints (the model of
/// `benches/simulate.py`): each link 0.5 m long, 1 kg, node at its centre of mass.
pub fn chain_yaml(n: usize) -> String {
    let mut s = String::from("gravity: [0, 0, -9.81]\nnodes:\n");
    for i in 0..n {
        s += &format!(
            "  - {{name: n{i}, position: [{}, 0, 0]}}\n",
            0.5 * (i as f64 + 0.5)
        );
    }
    s += "bodies:\n";
    for i in 0..n {
        s += &format!(
            "  - {{name: link{i}, node: n{i}, mass: 1.0, inertia: [0.001, 0.0208, 0.0208]}}\n"
        );
    }
    s += "joints:\n";
    for i in 0..n {
        let prev = if i == 0 {
            "ground".to_string()
        } else {
            format!("n{}", i - 1)
        };
        s += &format!(
            "  - {{type: revolute, name: pin{i}, node1: {prev}, node2: n{i}, axis: [0, 1, 0], position: [{}, 0, 0]}}\n",
            0.5 * i as f64
        );
    }
    s + "simulation: {dt: 0.001}\n"
}

/// YAML of a 2 kg collar on a sliding joint at `eta` (0…1) along a free 2.4 m beam of six
/// cubic elements, no gravity: at rest, and its window moves when `eta` is placed elsewhere.
pub fn collar_on_free_beam_yaml(eta: f64) -> String {
    let at = 2.4 * eta;
    format!(
        "
nodes:
  - {{name: collar, position: [{at}, 0, 0]}}
bodies:
  - {{name: collar_mass, node: collar, mass: 2.0, inertia: [0.01, 0.02, 0.03]}}
beams:
  - name: beam
    start: [0, 0, 0]
    end: [2.4, 0, 0]
    elements: 6
    order: 3
    section: {{ea: 1.0e5, ga2: 5.0e4, ga3: 5.0e4, gj: 400, ei2: 500, ei3: 500, m: 1.6, i22: 1.0e-3, i33: 1.0e-3}}
joints:
  - {{type: sliding, name: slider, beam: beam, follower: collar, eta: {eta}}}
"
    )
}
