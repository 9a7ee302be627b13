//! A beam section as the model file gives it: the usual shorthand or full 6×6 matrices. The
//! compiler turns it into the physics' `Section`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The usual shorthand of a section: principal stiffnesses about the tension and shear
/// centres, and mass properties about the centre of mass, with the centres' offsets (x₂, x₃)
/// from the reference line.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Shorthand {
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
    #[serde(default)]
    pub i23: f64,
    #[serde(default)]
    pub cm_offset: [f64; 2],
    #[serde(default)]
    pub tension_center: [f64; 2],
    #[serde(default)]
    pub shear_center: [f64; 2],
}

/// Full sectional matrices in the section frame (axis 1 along the beam), strains ordered
/// `[e₁, γ₂, γ₃, κ₁, κ₂, κ₃]` and velocities `[v, ω]`; both symmetric positive definite.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Matrices {
    /// 6×6 stiffness, rows of N (forces) and N·m (moments) per unit strain/curvature.
    pub stiffness: [[f64; 6]; 6],
    /// 6×6 mass per unit length about the reference line.
    pub mass: [[f64; 6]; 6],
}

/// An isotropic material: `E`, `density`, and either `G` or Poisson's ratio `nu`.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Young's modulus, Pa.
    #[serde(rename = "E")]
    pub e: f64,
    /// Shear modulus, Pa (or give `nu`).
    #[serde(rename = "G", default, skip_serializing_if = "Option::is_none")]
    pub g: Option<f64>,
    /// Poisson's ratio, instead of `G`: `G = E / 2(1 + ν)`, −1 < ν ≤ 0.5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nu: Option<f64>,
    /// Density, kg/m³.
    pub density: f64,
}

impl MaterialSpec {
    /// The shear modulus, Pa: `G` as given, or from `E` and `nu`; an error says which of the
    /// two to give when neither or both are.
    pub fn shear_modulus(&self) -> Result<f64, String> {
        match (self.g, self.nu) {
            (Some(g), None) => Ok(g),
            (None, Some(nu)) if nu > -1.0 && nu <= 0.5 => Ok(self.e / (2.0 * (1.0 + nu))),
            (None, Some(nu)) => Err(format!(
                "material: Poisson's ratio nu must lie in (-1, 0.5] (got {nu})"
            )),
            (None, None) => Err("material: give the shear modulus `G` (Pa) or Poisson's \
                 ratio `nu`"
                .into()),
            (Some(_), Some(_)) => {
                Err("material: give `G` or `nu`, not both (G = E / 2(1 + nu))".into())
            }
        }
    }
}

/// A cross-section shape, dimensions in m; `width` runs along the section's axis 2 and
/// `height` along axis 3 (up, for a horizontal beam).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Copy, Debug, PartialEq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeSpec {
    Rectangle {
        width: f64,
        height: f64,
    },
    Circle {
        diameter: f64,
    },
    Tube {
        diameter: f64,
        wall: f64,
    },
    Box {
        width: f64,
        height: f64,
        wall: f64,
    },
    /// Flanges `width` × `flange` thick, total `height`, web `web` thick (strong about axis 2).
    IBeam {
        width: f64,
        height: f64,
        flange: f64,
        web: f64,
    },
}

/// A section from a material and a shape: `{material: {E, G (or nu), density}, shape: {tube:
/// {diameter, wall}}}`.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialShape {
    pub material: MaterialSpec,
    pub shape: ShapeSpec,
}

/// A beam's `section:`: the shorthand (`ea`, `ga2`, …), full `stiffness` and `mass`
/// matrices, or a `material` and `shape`.
#[derive(Serialize, JsonSchema, Clone, Debug, PartialEq)]
#[serde(untagged)]
pub enum SectionSpec {
    Matrices(Matrices),
    MaterialShape(MaterialShape),
    Shorthand(Shorthand),
}

impl<'de> Deserialize<'de> for SectionSpec {
    /// Chooses the form by its keys, so that an error names the missing or wrong field of
    /// the form the user meant rather than "matched no variant".
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let v = serde_json::Value::deserialize(d)?;
        let full = v.get("stiffness").is_some() || v.get("mass").is_some();
        if v.get("material").is_some() || v.get("shape").is_some() {
            if let Some(shape) = v.get("shape") {
                check_shape_form(shape).map_err(D::Error::custom)?;
            }
            form(v).map(SectionSpec::MaterialShape)
        } else if full {
            form(v).map(SectionSpec::Matrices)
        } else {
            form(v).map(SectionSpec::Shorthand)
        }
    }
}

/// One form of a section from its keys, an error prefixed with the path inside the section
/// (e.g. `material.E: …`).
fn form<T: serde::de::DeserializeOwned, E: serde::de::Error>(v: serde_json::Value) -> Result<T, E> {
    serde_path_to_error::deserialize(v).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        match path.as_str() {
            "." => E::custom(inner),
            _ => E::custom(format!("{path}: {inner}")),
        }
    })
}

/// A shape names its kind as its only key (`{rectangle: {width, height}}`): serde's own
/// message for another map ("expected map with a single key") does not say so.
fn check_shape_form(shape: &serde_json::Value) -> Result<(), String> {
    match shape.as_object() {
        Some(map) if map.len() != 1 || map.contains_key("type") => Err(
            "shape: name the kind as its only key, its dimensions (m) inside it: e.g. `shape: \
             {rectangle: {width: 0.04, height: 0.03}}`; kinds: rectangle {width, height}, \
             circle {diameter}, tube {diameter, wall}, box {width, height, wall}, i_beam \
             {width, height, flange, web}"
                .into(),
        ),
        _ => Ok(()),
    }
}

impl From<Shorthand> for SectionSpec {
    fn from(s: Shorthand) -> Self {
        SectionSpec::Shorthand(s)
    }
}

/// A beam's structural damping (viscous, on its sections and optionally on its mass). The
/// sectional damping forces are `D ε̇` with `D = μ C + matrix` (C the section's stiffness);
/// the mass-proportional part applies `α m v` and `α J ω` at the beam's nodes.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BeamDamping {
    /// Stiffness-proportional coefficient μ, s: `D = μ C`, a modal damping ratio `ζ = μ ω / 2`
    /// for a mode at ω rad/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_proportional: Option<f64>,
    /// Instead of μ: the damping ratio ζ (e.g. 0.01 for 1 %) at `frequency`, Hz
    /// (`μ = ζ / (π f)`; higher modes get proportionally more).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratio: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frequency: Option<f64>,
    /// A 6×6 sectional damping matrix, section frame, rows of N·s (forces) and N·m·s (moments)
    /// per unit strain rate; symmetric positive semi-definite. Added to `μ C`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub matrix: Option<[[f64; 6]; 6]>,
    /// Mass-proportional coefficient α, 1/s (`ζ = α / (2ω)`). It resists *absolute* velocity,
    /// rigid motion included: use it only for structures on fixed supports.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass_proportional: Option<f64>,
}

impl BeamDamping {
    /// The stiffness-proportional coefficient μ, s (from `ratio` and `frequency` if given so).
    pub fn mu(&self) -> f64 {
        match (self.stiffness_proportional, self.ratio, self.frequency) {
            (Some(mu), _, _) => mu,
            (None, Some(z), Some(f)) if f > 0.0 => z / (std::f64::consts::PI * f),
            _ => 0.0,
        }
    }

    /// The sectional damping matrix of a section of stiffness `c`, if any.
    pub fn section_matrix(&self, c: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
        let mu = self.mu();
        if mu == 0.0 && self.matrix.is_none() {
            return None;
        }
        let extra = self.matrix.unwrap_or([[0.0; 6]; 6]);
        Some(std::array::from_fn(|i| {
            std::array::from_fn(|j| mu * c[i][j] + extra[i][j])
        }))
    }
}
