//! Geometrically exact beams: reference lines and section frames (`geometry`), sections,
//! Lagrange shape functions and Gauss rules (`shape`), the element's discrete forces, and
//! distributed loads that follow the sections (`line_load`).
pub mod element;
pub mod geometry;
mod lanes;
pub mod line_load;
pub mod path;
pub mod section;
pub mod section_shapes;
pub mod shape;
mod tangent;
