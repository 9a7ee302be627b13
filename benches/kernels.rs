//! Criterion benchmarks of the inner kernels: rotation maps and one Newton iteration
//! (assembly with exact tangents, numeric LU with the symbolic analysis reused, solve).

use criterion::{criterion_group, criterion_main, Criterion};
use flexdyn::integrator::Integrator;
use flexdyn::model::{from_yaml_str, Scheme};
use flexdyn::rotation::{cayley, exp_map, log_map};
use flexdyn::simulation::Simulation;
use flexdyn::vec3::V3;
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
    ] {
        for scheme in [Scheme::Ep, Scheme::Ed] {
            let mut sim = Simulation::with_scheme(&model, scheme).unwrap();
            sim.advance_to(0.1).unwrap();
            let h = sim.settings.dt;
            let mut integ = Integrator::new(&sim.system, &sim.settings);
            let ctx = sim.ctx(h);
            integ.predict(&sim.system, &sim.state, h);
            let name = format!("newton_iteration/{label}_{scheme:?}").to_lowercase();
            c.bench_function(&name, |b| {
                b.iter(|| {
                    integ.predict(&sim.system, &sim.state, h);
                    integ.newton_iteration(&sim.system, &ctx).unwrap()
                })
            });
            let name = format!("assembly/{label}_{scheme:?}").to_lowercase();
            c.bench_function(&name, |b| {
                b.iter(|| integ.assemble(&sim.system, &ctx, true))
            });
            let name = format!("factorization/{label}_{scheme:?}").to_lowercase();
            integ.assemble(&sim.system, &ctx, true);
            c.bench_function(&name, |b| b.iter(|| integ.matrix.factor().unwrap()));
        }
    }
}

criterion_group!(benches, rotations, newton_iteration);
criterion_main!(benches);
