//! Sections from a material and a cross-section shape: the engineering properties of solid
//! and thin-walled shapes (Roark's formulas; Cowper's shear coefficients for round sections),
//! so that stiffnesses need not be typed by hand.
//!
//! The section frame's axis 2 is horizontal and axis 3 up for a horizontal beam (README): a
//! shape's `width` runs along axis 2 and its `height` along axis 3.

use super::section::SectionProperties;

/// An isotropic material: Young's modulus E and shear modulus G (Pa), density ρ (kg/m³).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub e: f64,
    pub g: f64,
    pub rho: f64,
}

/// Cross-section shapes, dimensions in m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Solid rectangle `width` (along axis 2) × `height` (along axis 3).
    Rectangle { width: f64, height: f64 },
    /// Solid circle.
    Circle { diameter: f64 },
    /// Round tube of outer diameter and wall thickness.
    Tube { diameter: f64, wall: f64 },
    /// Rectangular hollow section: outer width × height, uniform wall.
    Box { width: f64, height: f64, wall: f64 },
    /// I (H) section: flanges `width` × `flange`, total `height`, web `web` thick (web along
    /// axis 3, so strong-axis bending is about axis 2).
    IBeam {
        width: f64,
        height: f64,
        flange: f64,
        web: f64,
    },
}

/// Area, second moments I₂ = ∫x₃², I₃ = ∫x₂², torsion constant J, and shear areas A₂, A₃.
struct Geometry {
    area: f64,
    i2: f64,
    i3: f64,
    j: f64,
    shear2: f64,
    shear3: f64,
}

impl Shape {
    /// Checks the dimensions: positive, walls thinner than half the outer size.
    pub fn check(&self) -> Result<(), String> {
        let dims: Vec<f64> = match *self {
            Shape::Rectangle { width, height } => vec![width, height],
            Shape::Circle { diameter } => vec![diameter],
            Shape::Tube { diameter, wall } => {
                if wall >= diameter / 2.0 {
                    return Err(format!("tube: the wall ({wall} m) must be thinner than the radius ({} m); for a solid bar use circle", diameter / 2.0));
                }
                vec![diameter, wall]
            }
            Shape::Box {
                width,
                height,
                wall,
            } => {
                if 2.0 * wall >= width.min(height) {
                    return Err(format!("box: two walls ({} m) must be narrower than the width and height; for a solid bar use rectangle", 2.0 * wall));
                }
                vec![width, height, wall]
            }
            Shape::IBeam {
                width,
                height,
                flange,
                web,
            } => {
                if 2.0 * flange >= height || web >= width {
                    return Err("i_beam: the flanges (2 × flange) must be thinner than the height and the web thinner than the width".into());
                }
                vec![width, height, flange, web]
            }
        };
        if dims.iter().all(|d| d.is_finite() && *d > 0.0) {
            Ok(())
        } else {
            Err("dimensions must be finite and > 0, m".into())
        }
    }

    /// Area, second moments, torsion constant and shear areas (ν for Cowper's coefficients).
    fn geometry(&self, nu: f64) -> Geometry {
        match *self {
            Shape::Box { .. } | Shape::IBeam { .. } => self.walled(),
            _ => self.solid_or_round(nu),
        }
    }

    fn solid_or_round(&self, nu: f64) -> Geometry {
        use std::f64::consts::PI;
        match *self {
            Shape::Rectangle {
                width: b,
                height: h,
            } => {
                let (a, t) = (0.5 * b.max(h), 0.5 * b.min(h));
                // Roark, table 10.1 case 4: J = a t³ (16/3 − 3.36 t/a (1 − t⁴/12a⁴)).
                let j = a
                    * t.powi(3)
                    * (16.0 / 3.0 - 3.36 * t / a * (1.0 - t.powi(4) / (12.0 * a.powi(4))));
                let k = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu); // Cowper
                Geometry {
                    area: b * h,
                    i2: b * h.powi(3) / 12.0,
                    i3: h * b.powi(3) / 12.0,
                    j,
                    shear2: k * b * h,
                    shear3: k * b * h,
                }
            }
            // A solid circle is a tube with no bore (Cowper's hollow formula at m = 0 is the
            // solid one).
            Shape::Circle { diameter: d } => Shape::Tube {
                diameter: d,
                wall: 0.5 * d,
            }
            .geometry(nu),
            Shape::Tube {
                diameter: d,
                wall: t,
            } => {
                let di = d - 2.0 * t;
                let i = PI * (d.powi(4) - di.powi(4)) / 64.0;
                let area = PI * (d * d - di * di) / 4.0;
                // Cowper, hollow circle with m = dᵢ/d.
                let m2 = (di / d).powi(2);
                let k = 6.0 * (1.0 + nu) * (1.0 + m2).powi(2)
                    / ((7.0 + 6.0 * nu) * (1.0 + m2).powi(2) + (20.0 + 12.0 * nu) * m2);
                Geometry {
                    area,
                    i2: i,
                    i3: i,
                    j: 2.0 * i,
                    shear2: k * area,
                    shear3: k * area,
                }
            }
            _ => unreachable!("walled shapes"),
        }
    }

    fn walled(&self) -> Geometry {
        match *self {
            Shape::Box {
                width: b,
                height: h,
                wall: t,
            } => {
                let (bi, hi) = (b - 2.0 * t, h - 2.0 * t);
                // Bredt: J = 4 A_m² t / perimeter of the wall's mid-line.
                let (bm, hm) = (b - t, h - t);
                Geometry {
                    area: b * h - bi * hi,
                    i2: (b * h.powi(3) - bi * hi.powi(3)) / 12.0,
                    i3: (h * b.powi(3) - hi * bi.powi(3)) / 12.0,
                    j: 4.0 * (bm * hm).powi(2) * t / (2.0 * (bm + hm)),
                    shear2: 2.0 * b * t,
                    shear3: 2.0 * h * t,
                }
            }
            Shape::IBeam {
                width: b,
                height: h,
                flange: tf,
                web: tw,
            } => {
                let hw = h - 2.0 * tf;
                Geometry {
                    area: 2.0 * b * tf + hw * tw,
                    i2: (b * h.powi(3) - (b - tw) * hw.powi(3)) / 12.0,
                    i3: (2.0 * tf * b.powi(3) + hw * tw.powi(3)) / 12.0,
                    j: (2.0 * b * tf.powi(3) + (h - tf) * tw.powi(3)) / 3.0,
                    shear2: 5.0 / 6.0 * 2.0 * b * tf,
                    shear3: h * tw,
                }
            }
            _ => unreachable!("solid shapes"),
        }
    }
}

/// The section of `material` and `shape`, about its centroid (which is also its shear centre:
/// the shapes are doubly symmetric).
pub fn properties(material: &Material, shape: &Shape) -> SectionProperties {
    let nu = (material.e / (2.0 * material.g) - 1.0).clamp(0.0, 0.5);
    let g = shape.geometry(nu);
    SectionProperties {
        ea: material.e * g.area,
        ga2: material.g * g.shear2,
        ga3: material.g * g.shear3,
        gj: material.g * g.j,
        ei2: material.e * g.i2,
        ei3: material.e * g.i3,
        m: material.rho * g.area,
        i22: material.rho * g.i2,
        i33: material.rho * g.i3,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEEL: Material = Material {
        e: 2.1e11,
        g: 8.1e10,
        rho: 7850.0,
    };

    #[test]
    fn a_thin_tube_and_a_thin_box_approach_their_thin_walled_formulas() {
        let (d, t) = (0.1, 1e-4);
        let p = properties(
            &STEEL,
            &Shape::Tube {
                diameter: d,
                wall: t,
            },
        );
        let r = (d - t) / 2.0;
        let i = std::f64::consts::PI * r.powi(3) * t;
        assert!((p.ei2 / (STEEL.e * i) - 1.0).abs() < 1e-3);
        assert!((p.gj / (STEEL.g * 2.0 * i) - 1.0).abs() < 1e-3);
        // Cowper's thin-walled tube: k → 2(1 + ν)/(4 + 3ν).
        let nu = STEEL.e / (2.0 * STEEL.g) - 1.0;
        let k = 2.0 * (1.0 + nu) / (4.0 + 3.0 * nu);
        assert!((p.ga2 / (STEEL.g * 2.0 * std::f64::consts::PI * r * t) / k - 1.0).abs() < 1e-2);
        let b = properties(
            &STEEL,
            &Shape::Box {
                width: 0.1,
                height: 0.1,
                wall: t,
            },
        );
        // Bredt for a thin square: J = a³ t (a the mid-line side), I = 2/3 a³ t.
        let a: f64 = 0.1 - t;
        assert!((b.gj / (STEEL.g * a.powi(3) * t) - 1.0).abs() < 1e-3);
        assert!((b.ei2 / (STEEL.e * 2.0 / 3.0 * a.powi(3) * t) - 1.0).abs() < 2e-3);
    }

    #[test]
    fn a_square_and_a_thin_strip_have_roarks_torsion_constants() {
        let sq = properties(
            &STEEL,
            &Shape::Rectangle {
                width: 0.02,
                height: 0.02,
            },
        );
        // Square: J = 0.1406 a⁴ (a the side); Roark's formula gives 0.1408 (0.15 %).
        assert!((sq.gj / (STEEL.g * 0.1406 * 0.02f64.powi(4)) - 1.0).abs() < 3e-3);
        let strip = properties(
            &STEEL,
            &Shape::Rectangle {
                width: 0.1,
                height: 0.001,
            },
        );
        // Thin strip: J → b t³/3 (1 − 0.63 t/b).
        let j = 0.1 * 1e-9 / 3.0 * (1.0 - 0.63 * 0.01);
        assert!((strip.gj / (STEEL.g * j) - 1.0).abs() < 1e-3);
        // Width along axis 2: (b/h)² = 1e4 times stiffer about axis 3.
        assert!((strip.ei3 / strip.ei2 / 1e4 - 1.0).abs() < 1e-9);
    }

    #[test]
    fn an_i_beam_is_stiff_about_axis_2_and_its_web_takes_the_vertical_shear() {
        let p = properties(
            &STEEL,
            &Shape::IBeam {
                width: 0.1,
                height: 0.2,
                flange: 0.01,
                web: 0.006,
            },
        );
        let area = 2.0 * 0.1 * 0.01 + 0.18 * 0.006;
        assert!((p.m / (STEEL.rho * area) - 1.0).abs() < 1e-12);
        assert!(p.ei2 > 5.0 * p.ei3);
        assert!((p.ga3 / (STEEL.g * 0.2 * 0.006) - 1.0).abs() < 1e-12);
        for bad in [
            Shape::IBeam {
                width: 0.1,
                height: 0.02,
                flange: 0.01,
                web: 0.006,
            },
            Shape::Tube {
                diameter: 0.1,
                wall: 0.06,
            },
        ] {
            assert!(bad.check().is_err());
        }
    }
}
