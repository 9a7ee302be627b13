//! The joints' relative coordinates, constraint rows and drive rows, numbered as the joints
//! compile; their kernels are built once the layout (which needs the counts) is known.

use crate::beam::path::ArcMap;
use crate::elements::coordinate::{CoordinateDrive, CoordinateSpring, SpringLaw};
use crate::joints::Joint;
use crate::math::layout::Layout;
use crate::math::time_function::TimeFunction;
use crate::system::JointInfo;

/// Builds a joint's kernel from its first constraint row and the layout.
pub type BuildJoint = Box<dyn FnOnce(usize, &Layout) -> Joint>;

struct PendingJoint {
    name: String,
    rows: usize,
    build: BuildJoint,
}

struct PendingDrive {
    name: String,
    coord: usize,
    function: TimeFunction,
    /// A sliding drive's map from η to the element coordinate ζ.
    map: Option<ArcMap>,
}

struct PendingSpring {
    coord: usize,
    law: SpringLaw,
    damping: f64,
}

/// Coordinates, joints, drives and springs in the order they were added.
#[derive(Default)]
pub struct RowTable {
    pub coord_names: Vec<String>,
    pub coords0: Vec<f64>,
    pub joint_info: Vec<JointInfo>,
    joints: Vec<PendingJoint>,
    drives: Vec<PendingDrive>,
    springs: Vec<PendingSpring>,
}

/// The kernels on the coordinates and rows, and each row's owner.
pub struct Rows {
    pub joints: Vec<Joint>,
    pub springs: Vec<CoordinateSpring>,
    pub drives: Vec<CoordinateDrive>,
    /// Per constraint row: the owning item's name and its local row (drive rows last).
    pub row_names: Vec<(String, usize)>,
}

impl RowTable {
    /// A new relative coordinate with its value at t = 0; returns its index.
    pub fn coordinate(&mut self, name: String, value0: f64) -> usize {
        self.coord_names.push(name);
        self.coords0.push(value0);
        self.coords0.len() - 1
    }

    /// A drive prescribing coordinate `coord` (one row, named `name`); returns its index.
    pub fn drive(
        &mut self,
        coord: usize,
        name: String,
        function: TimeFunction,
        map: Option<ArcMap>,
    ) -> usize {
        self.drives.push(PendingDrive {
            name,
            coord,
            function,
            map,
        });
        self.drives.len() - 1
    }

    /// A spring (and damper) on coordinate `coord`; returns its index.
    pub fn spring(&mut self, coord: usize, law: SpringLaw, damping: f64) -> usize {
        self.springs.push(PendingSpring {
            coord,
            law,
            damping,
        });
        self.springs.len() - 1
    }

    /// A joint of `rows` constraint rows; returns its kernel index.
    pub fn joint(&mut self, name: String, rows: usize, build: BuildJoint) -> usize {
        self.joints.push(PendingJoint { name, rows, build });
        self.joints.len() - 1
    }

    /// Constraint rows: the joints', then one per drive.
    pub fn n_rows(&self) -> usize {
        self.joints.iter().map(|j| j.rows).sum::<usize>() + self.drives.len()
    }

    /// The kernels, joint rows first and drive rows after them.
    pub fn build(&mut self, layout: &Layout) -> Rows {
        let mut row_names = Vec::with_capacity(self.n_rows());
        let mut row = 0;
        let joints = self
            .joints
            .drain(..)
            .map(|j| {
                row_names.extend((0..j.rows).map(|k| (j.name.clone(), k)));
                row += j.rows;
                (j.build)(row - j.rows, layout)
            })
            .collect();
        let drives = self
            .drives
            .drain(..)
            .enumerate()
            .map(|(k, d)| {
                row_names.push((d.name, 0));
                let mut kernel = CoordinateDrive::new(d.coord, row + k, d.function, layout);
                kernel.map = d.map;
                kernel
            })
            .collect();
        let springs = self
            .springs
            .drain(..)
            .map(|s| CoordinateSpring::new(s.coord, s.law, s.damping, layout))
            .collect();
        Rows {
            joints,
            springs,
            drives,
            row_names,
        }
    }
}
