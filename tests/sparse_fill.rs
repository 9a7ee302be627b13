//! Sparsity of the Newton matrix on a model whose size grows.
use flexdyn::compile::from_yaml_str;
use flexdyn::integrator::Integrator;
use flexdyn::model::Scheme;
use flexdyn::simulation::Simulation;
/// The fill of the Newton matrix's LU factors stays bounded on a long chain (a regression
/// guard for the ordering: AMD gave 14× the matrix's entries under ED, RCM gives 3×).
#[test]
fn lu_fill_stays_bounded_on_a_chain() {
    let model = from_yaml_str(&flexdyn::testing::chain_yaml(64)).unwrap();
    for scheme in [Scheme::Ep, Scheme::Ed] {
        let mut sim = Simulation::with_scheme(&model, scheme).unwrap();
        sim.advance_to(0.01).unwrap();
        let h = sim.settings.dt;
        let mut integ = Integrator::new(&sim.system, &sim.settings);
        let ctx = sim.ctx(h);
        integ.predict(&sim.system, &sim.state, h);
        integ.assemble(&sim.system, &ctx, true);
        integ.matrix.factor().unwrap();
        let (a, lu) = (integ.matrix.nnz(), integ.matrix.factor_nnz());
        assert!(lu <= 4 * a, "{scheme:?}: nnz(A) = {a}, nnz(LU) = {lu}");
    }
}
