//! Compiling a [`Model`](crate::model::Model) into numbered unknowns and kernels.
pub mod layout;
