//! The joints' relative coordinates, constraint rows and drive rows, numbered as the joints
//! compile; their kernels are built once the layout (which needs the counts) is known.

use crate::beam::path::ArcMap;
use crate::elements::coordinate::{CoordinateDrive, CoordinateSpring, SpringLaw};
use crate::joints::friction::{self, Coefficients, Friction, Normal, Slip};
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

struct PendingFriction {
    name: String,
    /// The joint's kernel, whose rows `normal` and `moment` name (local rows).
    joint: usize,
    coefficients: Coefficients,
    slip: Slip,
    coords: Vec<usize>,
    normal: Normal,
    moment: Option<(usize, f64)>,
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
    frictions: Vec<PendingFriction>,
}

/// The kernels on the coordinates and rows, and each row's owner.
pub struct Rows {
    pub joints: Vec<Joint>,
    pub springs: Vec<CoordinateSpring>,
    pub drives: Vec<CoordinateDrive>,
    pub frictions: Vec<Friction>,
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

    /// Friction on joint kernel `joint`'s coordinates `coords`, its normal force from the
    /// joint's (local) rows; one row of its own.
    #[allow(clippy::too_many_arguments)]
    pub fn friction(
        &mut self,
        name: &str,
        joint: usize,
        coefficients: Coefficients,
        slip: Slip,
        coords: Vec<usize>,
        normal: Normal,
        moment: Option<(usize, f64)>,
    ) {
        self.frictions.push(PendingFriction {
            name: name.to_string(),
            joint,
            coefficients,
            slip,
            coords,
            normal,
            moment,
        });
    }

    /// Constraint rows: the joints', then one per drive, then one per friction.
    pub fn n_rows(&self) -> usize {
        self.joints.iter().map(|j| j.rows).sum::<usize>() + self.drives.len() + self.frictions.len()
    }

    /// The kernels, joint rows first, drive rows after them, friction rows last; frictions
    /// append their history to `history`.
    pub fn build(&mut self, layout: &Layout, history: &mut Vec<f64>) -> Rows {
        let mut row_names = Vec::with_capacity(self.n_rows());
        let mut row = 0;
        let n_drives = self.drives.len();
        let mut row0 = Vec::with_capacity(self.joints.len());
        let joints = self
            .joints
            .drain(..)
            .map(|j| {
                row_names.extend((0..j.rows).map(|k| (j.name.clone(), k)));
                row0.push(row);
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
        let first_friction = row + n_drives;
        let frictions = self
            .frictions
            .drain(..)
            .enumerate()
            .map(|(k, f)| {
                row_names.push((format!("{}.friction", f.name), 0));
                let at = row0[f.joint];
                let h0 = history.len();
                // Sliding until the run sets its mode from the initial velocities (a stick
                // row would hold the initial velocity projection's slip).
                history.extend([1.0, 0.0, -1.0, 0.0]);
                debug_assert_eq!(friction::HISTORY_LEN, 4);
                let mut kernel = Friction::new(
                    f.name,
                    f.coefficients,
                    f.slip,
                    &f.coords,
                    f.normal.offset(at),
                    f.moment.map(|(r, inv)| (r + at, inv)),
                    first_friction + k,
                    h0,
                    layout,
                );
                kernel.kernel = f.joint;
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
            frictions,
            row_names,
        }
    }
}
