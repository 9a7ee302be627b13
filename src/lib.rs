//! flexdyn: flexible multibody dynamics with energy-preserving (EP) and energy-decaying (ED)
//! time integration and sliding joints on flexible beams (Bauchau & Bottasso 2001).
pub mod rotation;
pub mod scalar;
pub mod vec3;
pub mod model;
pub mod time_function;
pub mod elements;
pub mod joints;
pub mod state;
pub mod system;
