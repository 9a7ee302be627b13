//! Criterion benchmarks of the inner kernels: rotation maps and one Newton iteration
//! (assembly with exact tangents, numeric LU with the symbolic analysis reused, solve).

use criterion::{criterion_group, criterion_main, Criterion};
use flexdyn::compile::from_yaml_str;
use flexdyn::integrator::{Factors, Integrator};
use flexdyn::math::rotation::{cayley, exp_map, log_map};
use flexdyn::math::vec3::V3;
use flexdyn::model::Scheme;
use flexdyn::simulation::Simulation;
use std::hint::black_box;

fn rotations(c: &mut Criterion) {
    let r = V3([0.3, -0.7, 1.1]);
    c.bench_function("rotation/cayley", |b| b.iter(|| cayley(black_box(&r))));
    c.bench_function("rotation/exp_map", |b| b.iter(|| exp_map(black_box(&r))));
    let m = exp_map(&r);
    c.bench_function("rotation/log_map", |b| b.iter(|| log_map(black_box(&m))));
}

fn newton_iteration(c: &mut Criterion) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/four_bar.yaml"
    ))
    .unwrap();
    for (label, model) in [
        ("four_bar", from_yaml_str(&text).unwrap()),
        (
            "chain64",
            from_yaml_str(&flexdyn::testing::chain_yaml(64)).unwrap(),
        ),
        (
            "beam_pendulum",
            from_yaml_str(
                &std::fs::read_to_string(concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/examples/beam_pendulum.yaml"
                ))
                .unwrap(),
            )
            .unwrap(),
        ),
        (
            // A sliding joint on a 12-element cubic beam.
            "free_collar",
            from_yaml_str(
                &std::fs::read_to_string(concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/examples/free_collar.yaml"
                ))
                .unwrap(),
            )
            .unwrap(),
        ),
    ] {
        for scheme in [Scheme::Ep, Scheme::Ed] {
            let mut sim = Simulation::with_scheme(&model, scheme).unwrap();
            sim.advance_to(0.1).unwrap();
            let h = sim.settings.dt;
            let mut integ = Integrator::new(&sim.system, &sim.settings);
            let ctx = sim.ctx(h);
            let name = format!("predictor/{label}_{scheme:?}").to_lowercase();
            c.bench_function(&name, |b| {
                b.iter(|| integ.predict(&sim.system, &sim.state, h))
            });
            // Every timed iteration starts from the same predicted unknowns, restored by a copy:
            // the predictor runs once per step, not once per iteration.
            integ.predict(&sim.system, &sim.state, h);
            let predicted = integ.unknowns_mut().to_vec();
            let name = format!("newton_iteration/{label}_{scheme:?}").to_lowercase();
            c.bench_function(&name, |b| {
                b.iter(|| {
                    integ.unknowns_mut().copy_from_slice(&predicted);
                    integ.newton_iteration(&sim.system, &ctx).unwrap()
                })
            });
            let name = format!("assembly/{label}_{scheme:?}").to_lowercase();
            c.bench_function(&name, |b| {
                b.iter(|| integ.assemble(&sim.system, &ctx, true))
            });
            // A modified-Newton iteration with kept factors: residual only, back-substitution.
            let name = format!("residual/{label}_{scheme:?}").to_lowercase();
            c.bench_function(&name, |b| {
                b.iter(|| integ.assemble(&sim.system, &ctx, false))
            });
            let name = format!("factorization/{label}_{scheme:?}").to_lowercase();
            integ.assemble(&sim.system, &ctx, true);
            c.bench_function(&name, |b| b.iter(|| integ.matrix.factor().unwrap()));
            if scheme == Scheme::Ed {
                // The LU ED's exact iteration takes (by the 2×2 blocks of its motion pairs
                // where it can), not the scalar LU of the whole matrix above.
                let name = format!("factorization/{label}_ed_exact");
                c.bench_function(&name, |b| {
                    b.iter(|| integ.factor_tangent(Factors::Exact).unwrap())
                });
                // And its solve, what every iteration on kept exact factors pays (factored here:
                // a filtered run skips the timed factorizations above).
                integ.factor_tangent(Factors::Exact).unwrap();
                let residual = integ.residual_mut().to_vec();
                c.bench_function(&format!("solve/{label}_ed_exact"), |b| {
                    b.iter(|| {
                        integ.residual_mut().copy_from_slice(&residual);
                        integ.solve_residual()
                    })
                });
            }
            let name = format!("solve/{label}_{scheme:?}").to_lowercase();
            integ.matrix.factor().unwrap();
            let residual = integ.residual_mut().to_vec();
            let mut rhs = residual.clone();
            // The same right-hand side each time: repeated in-place solves would drift into
            // subnormal or overflowing numbers.
            c.bench_function(&name, |b| {
                b.iter(|| {
                    rhs.copy_from_slice(&residual);
                    integ.matrix.solve(&mut rhs)
                })
            });
            if scheme == Scheme::Ed {
                decoupled_iteration(c, label, &sim, &mut integ);
            }
        }
    }
}

/// ED's Newton iteration as modified Newton takes it with a fresh tangent (the default): the
/// rows the decoupled complex system reads, its LU and its solve.
fn decoupled_iteration(c: &mut Criterion, label: &str, sim: &Simulation, integ: &mut Integrator) {
    let h = sim.settings.dt;
    let ctx = sim.ctx(h);
    let d = Factors::Decoupled;
    integ.predict(&sim.system, &sim.state, h);
    let predicted = integ.unknowns_mut().to_vec();
    c.bench_function(&format!("newton_iteration/{label}_ed_decoupled"), |b| {
        b.iter(|| {
            integ.unknowns_mut().copy_from_slice(&predicted);
            integ.newton_iteration_with(&sim.system, &ctx, d).unwrap()
        })
    });
    c.bench_function(&format!("assembly/{label}_ed_decoupled"), |b| {
        b.iter(|| integ.assemble_tangent(&sim.system, &ctx, d))
    });
    integ.assemble_tangent(&sim.system, &ctx, d);
    c.bench_function(&format!("factorization/{label}_ed_decoupled"), |b| {
        b.iter(|| integ.factor_tangent(d).unwrap())
    });
    integ.factor_tangent(d).unwrap();
    let residual = integ.residual_mut().to_vec();
    c.bench_function(&format!("solve/{label}_ed_decoupled"), |b| {
        b.iter(|| {
            integ.residual_mut().copy_from_slice(&residual);
            integ.solve_residual()
        })
    });
}

/// One cubic beam element's residual and exact tangent (EP and ED), inside the beam pendulum.
fn beam_element(c: &mut Criterion) {
    use flexdyn::elements::Kernel;
    let yaml = r#"
gravity: [0, -9.81, 0]
nodes:
  - {name: root, position: [0, 0, 0]}
  - {name: tip, position: [2.4, 0, 0]}
bodies:
  - {name: tip_body, node: tip, mass: 40, inertia: [0.45, 0.225, 0.225]}
beams:
  - name: beam
    start_node: root
    end_node: tip
    elements: 12
    order: 3
    e2: [0, 1, 0]
    section: {ea: 44.0e6, ga2: 2.8e6, ga3: 14.0e6, gj: 28.0e3, ei2: 300.0e3, ei3: 23.0e3, m: 1.6, i22: 1.0e-3, i33: 11.0e-3}
joints:
  - {type: spherical, name: pin, node1: ground, node2: root, position: [0, 0, 0]}
simulation: {dt: 0.001}
"#;
    let model = from_yaml_str(yaml).unwrap();
    for scheme in [Scheme::Ep, Scheme::Ed] {
        let mut sim = Simulation::with_scheme(&model, scheme).unwrap();
        sim.advance_to(0.05).unwrap();
        let h = sim.settings.dt;
        let ctx = sim.ctx(h);
        let el = &sim.system.beams[5];
        let n = sim.system.layout.n_unknowns();
        let y: Vec<f64> = (0..n).map(|i| 1e-4 * (i as f64).sin()).collect();
        let m = el.unknowns().len();
        let pos = flexdyn::elements::own_block_positions(m);
        let mut vals = vec![0.0; m * m];
        let mut res = vec![0.0; n];
        let name = format!("beam_element/cubic_{scheme:?}").to_lowercase();
        c.bench_function(&name, |b| {
            b.iter(|| el.evaluate(&ctx, &y, &mut res, Some((&mut vals, &pos))))
        });
        // The residual alone: what each kept-factor Newton iteration pays per element.
        let name = format!("beam_element/cubic_{scheme:?}_residual").to_lowercase();
        let mut activity = vec![0.0; n];
        c.bench_function(&name, |b| {
            b.iter(|| el.residual_with_activity(&ctx, &y, &mut res, &mut activity))
        });
    }
}

criterion_group!(benches, rotations, newton_iteration, beam_element);
criterion_main!(benches);
