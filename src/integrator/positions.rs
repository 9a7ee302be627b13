//! Where each kernel's tangent block goes in a matrix's values: per kernel, the value
//! position of each of its `n × n` local entries (row-major), by kernel list.

use crate::elements::{value_pos, ValuePos};
use crate::system::System;

/// Value positions of every kernel's tangent block, one list per kernel kind (in the order
/// the system holds them).
#[derive(Clone, Debug, Default)]
pub struct KernelPositions {
    pub inertia: Vec<Vec<ValuePos>>,
    pub beam: Vec<Vec<ValuePos>>,
    pub joint: Vec<Vec<ValuePos>>,
    pub spring: Vec<Vec<ValuePos>>,
    pub drive: Vec<Vec<ValuePos>>,
    pub friction: Vec<Vec<ValuePos>>,
    pub load: Vec<Vec<ValuePos>>,
    pub line_load: Vec<Vec<ValuePos>>,
}

impl KernelPositions {
    /// Splits the blocks' positions, given in the system's kernel order (inertias, beams,
    /// joints, springs, drives, frictions, loads, line loads), by kind.
    pub fn split(sys: &System, mut pos: Vec<Vec<ValuePos>>) -> Self {
        let mut tail = |len: usize| pos.split_off(pos.len() - len);
        let line_load = tail(sys.line_loads.len());
        let load = tail(sys.loads.len());
        let friction = tail(sys.frictions.len());
        let drive = tail(sys.drives.len());
        let spring = tail(sys.springs.len());
        let joint = tail(sys.joints.len());
        let beam = tail(sys.beams.len());
        KernelPositions {
            inertia: pos,
            beam,
            joint,
            spring,
            drive,
            friction,
            load,
            line_load,
        }
    }

    /// The same blocks' positions in another matrix's values: `to(p)` for each position `p`.
    pub fn map(&self, to: impl Fn(usize) -> usize) -> Self {
        let to = |p: ValuePos| value_pos(to(p as usize));
        let each = |lists: &Vec<Vec<ValuePos>>| -> Vec<Vec<ValuePos>> {
            lists
                .iter()
                .map(|block| block.iter().map(|&p| to(p)).collect())
                .collect()
        };
        KernelPositions {
            inertia: each(&self.inertia),
            beam: each(&self.beam),
            joint: each(&self.joint),
            spring: each(&self.spring),
            drive: each(&self.drive),
            friction: each(&self.friction),
            load: each(&self.load),
            line_load: each(&self.line_load),
        }
    }
}
