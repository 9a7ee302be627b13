//! Angular momentum under a sliding joint (sliding-joint-notes §2.1): eq. (33)'s forces have
//! zero resultant but a net moment about the origin, `(Y_m − Σ h_m^α X_m^α) × F` with F the
//! force on the follower, which vanishes only when ζ stands still. With the EP scheme the
//! system's angular momentum must change, step by step, by exactly h times that moment —
//! to round-off, not merely O(h²) — while linear momentum is exact.

use flexdyn::compile::from_yaml_str;
use flexdyn::math::vec3::V3;
use flexdyn::simulation::Simulation;

#[test]
fn angular_momentum_changes_by_the_predicted_defect_of_eq_33() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/free_collar.yaml"
    ))
    .unwrap();
    let mut model = from_yaml_str(&text).unwrap();
    // Newton to near round-off, so that what is left is the identity's own error.
    model.simulation.newton_tol = 1e-13;
    let mut sim = Simulation::new(&model).unwrap();
    let h = sim.settings.dt;
    let sl = sim.system.joints[0].as_sliding().unwrap().clone();
    let mut worst = 0.0f64;
    let mut largest_defect = 0.0f64;
    let mut h_scale = 0.0f64;
    for k in 1..=2000 {
        let si = sim.state.clone();
        sim.advance_to(k as f64 * h).unwrap();
        let sf = sim.state.clone();
        let (_, hi) = sim.system.momentum(&si);
        let (_, hf) = sim.system.momentum(&sf);
        h_scale = h_scale.max(hi.norm());
        let force = sim.last_report.as_ref().unwrap().reactions[0].0;
        let (zi, zf) = (si.coords[sl.coord], sf.coords[sl.coord]);
        let mut p_m = V3::zero();
        for (zeta, weight) in [(zi, 0.5), (zf, 0.5)] {
            for (n, w) in sl.path.weights(zeta).iter() {
                let a = sl.beam_nodes[n];
                p_m += (si.nodes[a].x + sf.nodes[a].x).scale_f(0.5 * w * weight);
            }
        }
        let follower = match sl.follower {
            flexdyn::joints::Side::Node(a) => a,
            _ => unreachable!(),
        };
        let y_m = (si.nodes[follower].x + sf.nodes[follower].x).scale_f(0.5);
        let predicted = (y_m - p_m).cross(&force).scale_f(h);
        largest_defect = largest_defect.max(predicted.norm());
        worst = worst.max((hf - hi - predicted).norm());
    }
    eprintln!("dH - predicted {worst:e}, defect up to {largest_defect:e}, H {h_scale:e}");
    // The defect is real — largest when the collar bounces off an end stop (t ≈ 1.8 s,
    // measured 8e-10; ζ̇ and the contact force change fastest there) — and predicted to
    // round-off (measured 2e-15 with |H| = 1.08): the bound 1e-13 |H| lies three orders below
    // the defect, so a wrong prediction fails it.
    assert!(largest_defect > 1e-10, "defect {largest_defect:e}");
    assert!(
        worst < 1e-13 * h_scale,
        "ΔH − predicted = {worst:e} (defect up to {largest_defect:e}, |H| {h_scale:e})"
    );
}
