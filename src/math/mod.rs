//! The bottom layer: scalars (reals and dual numbers), small vectors and matrices, finite
//! rotations, functions of time (with the plain-data specs the file format reads them from),
//! and the numbering of a step's unknowns. It imports nothing else from the crate; the kernels
//! (beams, joints, elements), the compiler and the file format build on it.
pub mod default_axes;
pub mod layout;
pub mod rotation;
pub mod scalar;
pub mod seconds;
pub mod time_function;
pub mod vec3;
pub mod wide;
