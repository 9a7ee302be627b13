//! Geometrically exact beams (issue 3): shape functions and sections so far.
pub mod element;
pub mod section;
pub mod shape;
