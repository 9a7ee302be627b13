//! flexdyn: flexible multibody dynamics with energy-preserving (EP) and energy-decaying (ED)
//! time integration and sliding joints on flexible beams (Bauchau & Bottasso 2001).
pub mod beam;
pub mod compile;
pub mod elements;
pub mod fields;
pub mod integrator;
pub mod joints;
pub mod math;
pub mod model;
pub mod sensors;
pub mod simulation;
pub mod state;
pub mod system;
#[doc(hidden)]
pub mod testing;

#[cfg(feature = "python")]
mod python;
