//! Lagrange shape functions of 2-, 3- and 4-node beam elements (linear, quadratic, cubic) on
//! the parent coordinate ξ ∈ [−1, 1] with equally spaced nodes, and Gauss–Legendre rules.

/// Nodes of an element: 2, 3 or 4.
pub const MAX_NODES: usize = 4;

/// Parent coordinates of the nodes of an `n`-node element.
pub fn node_coordinates(n: usize) -> &'static [f64] {
    match n {
        2 => &[-1.0, 1.0],
        3 => &[-1.0, 0.0, 1.0],
        4 => &[-1.0, -1.0 / 3.0, 1.0 / 3.0, 1.0],
        _ => panic!("beam elements have 2, 3 or 4 nodes (got {n})"),
    }
}

/// Values `h^α(ξ)` and derivatives `dh^α/dξ` of the `n` shape functions.
pub fn lagrange(n: usize, xi: f64) -> ([f64; MAX_NODES], [f64; MAX_NODES]) {
    let z = node_coordinates(n);
    let mut h = [0.0; MAX_NODES];
    let mut dh = [0.0; MAX_NODES];
    for a in 0..n {
        let mut v = 1.0;
        let mut d = 0.0;
        for b in 0..n {
            if b == a {
                continue;
            }
            let den = z[a] - z[b];
            // Product rule: d(∏ fᵢ) = Σ f'ᵢ ∏_{j≠i} fⱼ, accumulated factor by factor.
            d = d * (xi - z[b]) / den + v / den;
            v *= (xi - z[b]) / den;
        }
        h[a] = v;
        dh[a] = d;
    }
    (h, dh)
}

/// Gauss–Legendre points and weights on [−1, 1] with `n` points (1 to 4); exact for
/// polynomials of degree 2n − 1.
pub fn gauss(n: usize) -> (&'static [f64], &'static [f64]) {
    const P2: f64 = 0.577_350_269_189_625_8; // 1/√3
    const P3: f64 = 0.774_596_669_241_483_4; // √(3/5)
    const P4A: f64 = 0.339_981_043_584_856_3;
    const P4B: f64 = 0.861_136_311_594_052_6;
    const W4A: f64 = 0.652_145_154_862_546_1;
    const W4B: f64 = 0.347_854_845_137_453_9;
    match n {
        1 => (&[0.0], &[2.0]),
        2 => (&[-P2, P2], &[1.0, 1.0]),
        3 => (&[-P3, 0.0, P3], &[5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0]),
        4 => (&[-P4B, -P4A, P4A, P4B], &[W4B, W4A, W4A, W4B]),
        _ => panic!("Gauss rules with 1 to 4 points (got {n})"),
    }
}

/// Reduced integration for an `n`-node element: `n − 1` points. It integrates the element's
/// stiffness without shear locking of thin beams (its strains are interpolated one degree
/// lower than the displacements).
pub fn reduced_points(n: usize) -> usize {
    n - 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partition_of_unity_and_kronecker_property() {
        for n in 2..=4 {
            for k in 0..=20 {
                let xi = -1.0 + 0.1 * k as f64;
                let (h, dh) = lagrange(n, xi);
                assert!((h[..n].iter().sum::<f64>() - 1.0).abs() < 1e-14);
                assert!(dh[..n].iter().sum::<f64>().abs() < 1e-13);
            }
            for (a, &za) in node_coordinates(n).iter().enumerate() {
                let (h, _) = lagrange(n, za);
                for (b, hb) in h[..n].iter().enumerate() {
                    assert!((hb - if a == b { 1.0 } else { 0.0 }).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn interpolates_polynomials_of_its_degree_exactly_with_derivatives() {
        // f(ξ) = ξ^(n−1) + 0.3 ξ − 2, interpolated from nodal values.
        for n in 2..=4 {
            let f = |x: f64| x.powi(n as i32 - 1) + 0.3 * x - 2.0;
            let df = |x: f64| (n as f64 - 1.0) * x.powi(n as i32 - 2) + 0.3;
            let z = node_coordinates(n);
            for k in 0..=10 {
                let xi = -1.0 + 0.2 * k as f64;
                let (h, dh) = lagrange(n, xi);
                let v: f64 = (0..n).map(|a| h[a] * f(z[a])).sum();
                let d: f64 = (0..n).map(|a| dh[a] * f(z[a])).sum();
                assert!((v - f(xi)).abs() < 1e-13, "n={n}");
                assert!((d - df(xi)).abs() < 1e-12, "n={n}");
            }
        }
    }

    #[test]
    fn gauss_rules_are_exact_to_degree_2n_minus_1() {
        for n in 1..=4 {
            let (x, w) = gauss(n);
            for deg in 0..2 * n {
                let num: f64 = x
                    .iter()
                    .zip(w)
                    .map(|(xi, wi)| wi * xi.powi(deg as i32))
                    .sum();
                let exact = if deg % 2 == 1 {
                    0.0
                } else {
                    2.0 / (deg as f64 + 1.0)
                };
                assert!((num - exact).abs() < 1e-14, "n={n} deg={deg}");
            }
        }
    }
}
