//! Beam cross-sections: the 6×6 sectional stiffness and mass matrices in the section frame.
//!
//! Sectional strains are ordered `[e₁, γ₂, γ₃, κ₁, κ₂, κ₃]` (axial strain, transverse shear
//! strains, twist and bending curvatures) and sectional velocities `[v₁ v₂ v₃, ω₁ ω₂ ω₃]`, all
//! measured at the reference line in the section frame (axis 1 along the beam).

use crate::math::vec3::{M3, V3};

pub type Mat6 = [[f64; 6]; 6];

/// The usual engineering description of a section: principal stiffnesses about the tension
/// and shear centres, and mass properties about the centre of mass, with the centres' offsets
/// (x₂, x₃) from the reference line. (The model file's `section:` shorthand maps onto it.)
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SectionProperties {
    /// Axial stiffness EA, N.
    pub ea: f64,
    /// Shear stiffnesses GA₂, GA₃ (including shear correction factors), N.
    pub ga2: f64,
    pub ga3: f64,
    /// Torsional stiffness GJ, N·m².
    pub gj: f64,
    /// Bending stiffnesses EI₂ (about axis 2, curvature κ₂) and EI₃, N·m².
    pub ei2: f64,
    pub ei3: f64,
    /// Mass per unit length, kg/m.
    pub m: f64,
    /// Mass moments of inertia per unit length about the centre of mass: i₂₂ = ∫ρx₃², i₃₃ =
    /// ∫ρx₂², i₂₃ = ∫ρx₂x₃ (kg·m); the polar moment is i₂₂ + i₃₃.
    pub i22: f64,
    pub i33: f64,
    pub i23: f64,
    /// Offsets (x₂, x₃) of the centre of mass, tension centre and shear centre, m.
    pub cm_offset: [f64; 2],
    pub tension_center: [f64; 2],
    pub shear_center: [f64; 2],
}

#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    pub stiffness: Mat6,
    pub mass: Mat6,
}

impl Section {
    /// Mass per unit length.
    pub fn mass_per_length(&self) -> f64 {
        self.mass[0][0]
    }

    /// Mass moments of inertia per unit length about the reference line (section frame).
    pub fn inertia_per_length(&self) -> M3<f64> {
        M3(std::array::from_fn(|i| {
            std::array::from_fn(|j| self.mass[3 + i][3 + j])
        }))
    }

    /// Centre of mass relative to the reference line, section frame: from the coupling block
    /// `m c̃` of the mass matrix.
    pub fn cm_offset(&self) -> V3<f64> {
        let m = self.mass[0][0];
        V3([
            self.mass[5][1] / m,
            self.mass[3][2] / m,
            self.mass[4][0] / m,
        ])
    }

    /// Beam mass is lumped at nodes as a point mass with inertia (at the centre of mass), so
    /// the translational block must be one mass per unit length times the identity, and the
    /// coupling block a cross product (`m c̃`).
    pub fn check_lumpable(&self) -> Result<(), String> {
        let m = self.mass[0][0];
        let iso = (0..3).all(|i| {
            (0..3).all(|j| (self.mass[i][j] - if i == j { m } else { 0.0 }).abs() <= 1e-12 * m)
        });
        let c = self.cm_offset();
        let mc = c.tilde().scale_f(m);
        let scale = self
            .mass
            .iter()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        let cross = (0..3)
            .all(|i| (0..3).all(|j| (self.mass[3 + i][j] - mc.0[i][j]).abs() <= 1e-12 * scale));
        if !cross {
            return Err("the mass matrix's coupling block (rows 4–6, columns 1–3) must be m·c̃ for a centre of mass c".into());
        }
        if !iso {
            return Err(
                "the translational block of the mass matrix must be m·I (one mass per unit length)"
                    .into(),
            );
        }
        Ok(())
    }

    /// `(1 − w) a + w b`, entry by entry.
    pub fn blend(a: &Section, b: &Section, w: f64) -> Section {
        let mix = |x: &Mat6, y: &Mat6| -> Mat6 {
            std::array::from_fn(|i| std::array::from_fn(|j| (1.0 - w) * x[i][j] + w * y[i][j]))
        };
        Section {
            stiffness: mix(&a.stiffness, &b.stiffness),
            mass: mix(&a.mass, &b.mass),
        }
    }

    /// From full matrices; both must be symmetric positive definite.
    pub fn from_matrices(stiffness: Mat6, mass: Mat6) -> Result<Section, String> {
        check_spd(&stiffness, "stiffness")?;
        check_spd(&mass, "mass")?;
        Ok(Section { stiffness, mass })
    }

    /// From engineering properties. The strain energy per unit length is
    /// `½EA(e₁ + x₃ᵗκ₂ − x₂ᵗκ₃)² + ½GA₂(γ₂ − x₃ˢκ₁)² + ½GA₃(γ₃ + x₂ˢκ₁)² + ½GJκ₁² + ½EI₂κ₂² + ½EI₃κ₃²`
    /// (axial strain at the tension centre, shear strains at the shear centre), and the kinetic
    /// energy `½m|v + ω × c|² + ½ωᵀJ_c ω` with the centre of mass at `c = (0, x₂ᶜ, x₃ᶜ)`.
    pub fn from_properties(s: &SectionProperties) -> Result<Section, String> {
        let named = [
            ("ea", s.ea),
            ("ga2", s.ga2),
            ("ga3", s.ga3),
            ("gj", s.gj),
            ("ei2", s.ei2),
            ("ei3", s.ei3),
            ("m", s.m),
        ];
        for (name, v) in named {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be positive (got {v})"));
            }
        }
        let [yt, zt] = s.tension_center;
        let [ys, zs] = s.shear_center;
        // Centred strains = T · reference strains.
        let mut t = [[0.0; 6]; 6];
        for (i, row) in t.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        t[0][4] = zt;
        t[0][5] = -yt;
        t[1][3] = -zs;
        t[2][3] = ys;
        let d = [s.ea, s.ga2, s.ga3, s.gj, s.ei2, s.ei3];
        let mut k = [[0.0; 6]; 6];
        for (i, ki) in k.iter_mut().enumerate() {
            for (j, kij) in ki.iter_mut().enumerate() {
                *kij = (0..6).map(|r| t[r][i] * d[r] * t[r][j]).sum();
            }
        }
        let c = V3([0.0, s.cm_offset[0], s.cm_offset[1]]);
        let jc = M3([
            [s.i22 + s.i33, 0.0, 0.0],
            [0.0, s.i22, -s.i23],
            [0.0, -s.i23, s.i33],
        ]);
        let ct = c.tilde();
        let m_c = ct.scale_f(s.m);
        let j_ref = jc - ct.mul_m(&ct).scale_f(s.m);
        let mut m = [[0.0; 6]; 6];
        for i in 0..3 {
            m[i][i] = s.m;
            for j in 0..3 {
                m[i][3 + j] = -m_c.0[i][j];
                m[3 + i][j] = m_c.0[i][j];
                m[3 + i][3 + j] = j_ref.0[i][j];
            }
        }
        Section::from_matrices(k, m).map_err(|e| {
            format!("{e} (check i22, i33 and i23: the section inertia must be positive definite)")
        })
    }
}

/// Symmetric and positive definite (Cholesky), with a message saying which. Judged on the
/// matrix scaled to a unit diagonal (`aᵢⱼ/√(aᵢᵢaⱼⱼ)`): its entries mix units (N for EA, N·m² for
/// EI), whose ratio is a radius of gyration squared, so a threshold relative to the largest
/// entry refused a 0.2 µm thick strip (GJ/EA = 5e-16), a sound section.
fn check_spd(a: &Mat6, what: &str) -> Result<(), String> {
    if !a.iter().flatten().all(|v| v.is_finite()) || a.iter().flatten().all(|&v| v == 0.0) {
        return Err(format!("{what} matrix must be finite and nonzero"));
    }
    if let Some(i) = (0..6).find(|&i| a[i][i] <= 0.0) {
        return Err(format!(
            "{what} matrix must be positive definite (diagonal entry {} is {:.3e})",
            i + 1,
            a[i][i]
        ));
    }
    let unit: [f64; 6] = std::array::from_fn(|i| 1.0 / a[i][i].sqrt());
    let b: Mat6 = std::array::from_fn(|i| std::array::from_fn(|j| a[i][j] * unit[i] * unit[j]));
    for i in 0..6 {
        for j in 0..i {
            if (b[i][j] - b[j][i]).abs() > 1e-12 {
                return Err(format!(
                    "{what} matrix must be symmetric (entry ({}, {}) differs from ({}, {}))",
                    i + 1,
                    j + 1,
                    j + 1,
                    i + 1
                ));
            }
        }
    }
    let mut l = [[0.0; 6]; 6];
    for j in 0..6 {
        let d = b[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        if d <= 1e-14 {
            return Err(format!(
                "{what} matrix must be positive definite (pivot {} is {d:.3e} of its diagonal entry)",
                j + 1
            ));
        }
        l[j][j] = d.sqrt();
        for i in j + 1..6 {
            l[i][j] = (b[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / l[j][j];
        }
    }
    Ok(())
}

/// A damping matrix: finite, symmetric and positive semi-definite (zero rows allowed, e.g. no
/// axial damping), so that its forces can only dissipate.
pub fn check_semidefinite(a: &Mat6) -> Result<(), String> {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale == 0.0 {
        return Ok(());
    }
    // A shift of 1e-10 of the largest entry makes a semi-definite matrix definite, while a
    // negative eigenvalue any larger than round-off still fails the factorization.
    let shifted: Mat6 = std::array::from_fn(|i| {
        std::array::from_fn(|j| a[i][j] + if i == j { 1e-10 * scale } else { 0.0 })
    });
    check_spd(&shifted, "damping")
        .map_err(|e| e.replace("positive definite", "positive semi-definite"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> SectionProperties {
        SectionProperties {
            ea: 44e6,
            ga2: 2.8e6,
            ga3: 14e6,
            gj: 28e3,
            ei2: 300e3,
            ei3: 23e3,
            m: 1.6,
            i22: 1.0e-3,
            i33: 11.0e-3,
            i23: 0.5e-3,
            cm_offset: [0.01, -0.02],
            tension_center: [0.015, 0.005],
            shear_center: [-0.01, 0.02],
        }
    }

    fn quad(a: &Mat6, x: &[f64; 6]) -> f64 {
        (0..6)
            .map(|i| (0..6).map(|j| x[i] * a[i][j] * x[j]).sum::<f64>())
            .sum::<f64>()
            * 0.5
    }

    #[test]
    fn beam_slider_section_without_offsets_is_diagonal() {
        // The paper's beam (section 7.1): EA 44 MN, GK 2.8/14 MN, GJ 28 kN·m², EI 300/23 kN·m².
        let s = SectionProperties {
            i23: 0.0,
            cm_offset: [0.0; 2],
            tension_center: [0.0; 2],
            shear_center: [0.0; 2],
            ..sample()
        };
        let sec = Section::from_properties(&s).unwrap();
        let d = [44e6, 2.8e6, 14e6, 28e3, 300e3, 23e3];
        for i in 0..6 {
            for j in 0..6 {
                assert_eq!(sec.stiffness[i][j], if i == j { d[i] } else { 0.0 });
            }
        }
        assert_eq!(sec.mass[3][3], 12.0e-3);
    }

    #[test]
    fn strain_and_kinetic_energies_match_their_definitions_with_offsets() {
        let s = sample();
        let sec = Section::from_properties(&s).unwrap();
        let eps = [1e-4, -2e-4, 3e-4, 0.01, -0.02, 0.015];
        let [yt, zt] = s.tension_center;
        let [ys, zs] = s.shear_center;
        let e = 0.5 * s.ea * (eps[0] + zt * eps[4] - yt * eps[5]).powi(2)
            + 0.5 * s.ga2 * (eps[1] - zs * eps[3]).powi(2)
            + 0.5 * s.ga3 * (eps[2] + ys * eps[3]).powi(2)
            + 0.5 * s.gj * eps[3].powi(2)
            + 0.5 * s.ei2 * eps[4].powi(2)
            + 0.5 * s.ei3 * eps[5].powi(2);
        assert!((quad(&sec.stiffness, &eps) - e).abs() < 1e-12 * e);
        let v = V3([0.3, -1.2, 0.7]);
        let w = V3([2.0, -0.5, 1.5]);
        let c = V3([0.0, s.cm_offset[0], s.cm_offset[1]]);
        let jc = M3([
            [s.i22 + s.i33, 0.0, 0.0],
            [0.0, s.i22, -s.i23],
            [0.0, -s.i23, s.i33],
        ]);
        let vc = v + w.cross(&c);
        let t = 0.5 * s.m * vc.norm_sq() + 0.5 * w.dot(&jc.mul_v(&w));
        let x = [v.0[0], v.0[1], v.0[2], w.0[0], w.0[1], w.0[2]];
        assert!((quad(&sec.mass, &x) - t).abs() < 1e-13 * t);
    }

    #[test]
    fn inadmissible_sections_are_errors() {
        assert!(Section::from_properties(&SectionProperties {
            ea: -1.0,
            ..sample()
        })
        .unwrap_err()
        .contains("ea must be positive"));
        let bad_inertia = SectionProperties {
            i23: 0.01,
            ..sample()
        }; // i23² > i22·i33
        assert!(Section::from_properties(&bad_inertia)
            .unwrap_err()
            .contains("positive definite"));
        let mut k = Section::from_properties(&sample()).unwrap().stiffness;
        k[0][1] += 1.0;
        let m = Section::from_properties(&sample()).unwrap().mass;
        assert!(Section::from_matrices(k, m)
            .unwrap_err()
            .contains("symmetric"));
    }

    /// Admissibility does not depend on the unit of length: the sample section shrunk by
    /// 10⁻³ and 10⁻⁶ (forces ∝ s², bending ∝ s⁴, offsets ∝ s; at 10⁻⁶ its GJ/EA is 6e-16,
    /// which a threshold relative to the largest entry refused) is as sound, and with
    /// `i23² > i22·i33` as unsound, at every size.
    #[test]
    fn a_sections_admissibility_is_the_same_at_any_size() {
        for scale in [1.0f64, 1e-3, 1e-6] {
            let (s2, s4) = (scale * scale, scale.powi(4));
            let base = sample();
            let small = SectionProperties {
                ea: base.ea * s2,
                ga2: base.ga2 * s2,
                ga3: base.ga3 * s2,
                gj: base.gj * s4,
                ei2: base.ei2 * s4,
                ei3: base.ei3 * s4,
                m: base.m * s2,
                i22: base.i22 * s4,
                i33: base.i33 * s4,
                i23: base.i23 * s4,
                cm_offset: base.cm_offset.map(|c| c * scale),
                tension_center: base.tension_center.map(|c| c * scale),
                shear_center: base.shear_center.map(|c| c * scale),
            };
            assert!(Section::from_properties(&small).is_ok(), "{scale}");
            let unsound = SectionProperties {
                i23: 1.01 * (small.i22 * small.i33).sqrt(),
                ..small
            };
            let e = Section::from_properties(&unsound).unwrap_err();
            assert!(e.contains("positive definite"), "{scale}: {e}");
        }
    }
}
