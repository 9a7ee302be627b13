use flexdyn::model::from_yaml_str;
use flexdyn::simulation::Simulation;

#[test]
fn pendulum_runs() {
    let m = from_yaml_str(
        r#"
gravity: [0, 0, -9.81]
nodes:
  - {name: bob, position: [1, 0, 0]}
bodies:
  - {name: ball, node: bob, mass: 2.0, inertia: [0.01, 0.01, 0.01]}
joints:
  - {type: revolute, name: pin, node1: ground, node2: bob, position: [0, 0, 0], axis: [0, 1, 0]}
sensors:
  - {type: energy, name: e}
simulation: {scheme: ep, t_end: 1.0, dt: 0.01}
"#,
    )
    .unwrap();
    for scheme in [flexdyn::model::Scheme::Ep, flexdyn::model::Scheme::Ed] {
        let mut sim = Simulation::with_scheme(&m, scheme).unwrap();
        sim.advance_to(1.0).unwrap();
        println!("{scheme:?} {:?} E={}", sim.stats, sim.energy());
        println!("{:?}", sim.last_report.as_ref().unwrap().residuals);
    }
}
