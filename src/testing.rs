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
