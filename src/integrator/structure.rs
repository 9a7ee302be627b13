//! Which entries of each kernel's tangent block can be nonzero: probed once per kernel and
//! kept, so that a rebuilt Newton matrix (a sliding joint's window moved) probes only the
//! kernels whose unknowns changed, and an integrator for the same system (the instant values
//! at a run's ends) takes the pattern as it is.

use crate::elements::{Kernel, StepCtx};
use crate::math::rotation::exp_map;
use crate::math::vec3::V3;
use crate::system::System;

/// Every kernel's block structure (row-major masks), in kernel order (inertias, beams,
/// joints, springs, drives, frictions, loads, line loads), and the unknowns and step size it
/// was probed for.
#[derive(Clone, Debug, Default)]
pub struct BlockStructure {
    h: f64,
    unknowns: Vec<Vec<usize>>,
    masks: Vec<Vec<bool>>,
    /// Masks probed per `(kernel, shape)` of kernels with a [`Kernel::structure_shape`]: a
    /// sliding joint's window that moves on takes its shape's mask (probing the joint's
    /// tangents at several contact points was half of a pattern rebuild).
    shapes: Vec<(usize, usize, Vec<bool>)>,
    /// Kernels probed to build it (the others' masks were kept from an earlier one).
    #[cfg_attr(not(test), allow(dead_code))] // read by the tests of what a rebuild probes
    pub probed: usize,
}

/// Runs `$body` with `$k` bound to every kernel of `$sys` in kernel order.
macro_rules! for_each_kernel {
    ($sys:expr, |$k:ident| $body:block) => {{
        let sys = $sys;
        for $k in sys.inertias.iter() $body
        for $k in sys.beams.iter() $body
        for $k in sys.joints.iter() $body
        for $k in sys.springs.iter() $body
        for $k in sys.drives.iter() $body
        for $k in sys.frictions.iter() $body
        for $k in sys.loads.iter() $body
        for $k in sys.line_loads.iter() $body
    }};
}

impl BlockStructure {
    /// Probes every kernel of `sys` for steps of size `h` (s).
    pub fn probe(sys: &System, h: f64) -> Self {
        Self::update(sys, h, None)
    }

    /// The structure of `sys` after some kernels' unknowns changed: the others' masks are
    /// this one's (a kernel's structure depends only on its unknowns: it is probed at fixed
    /// generic states, not the current one).
    pub fn reprobe(&self, sys: &System, h: f64) -> Self {
        Self::update(sys, h, Some(self))
    }

    /// The masks in kernel order.
    pub fn masks(&self) -> &[Vec<bool>] {
        &self.masks
    }

    /// Each kernel's unknowns in kernel order.
    pub fn unknowns(&self) -> Vec<&[usize]> {
        self.unknowns.iter().map(|u| &u[..]).collect()
    }

    fn update(sys: &System, h: f64, known: Option<&Self>) -> Self {
        let mut unknowns: Vec<Vec<usize>> = Vec::new();
        let mut kernel_shapes: Vec<Option<usize>> = Vec::new();
        for_each_kernel!(sys, |k| {
            unknowns.push(k.unknowns().to_vec());
            kernel_shapes.push(k.structure_shape());
        });
        let known = known.filter(|k| k.h == h && k.unknowns.len() == unknowns.len());
        let mut shapes = known.map_or_else(Vec::new, |k| k.shapes.clone());
        // A kernel keeps its mask if it has the same unknowns, or takes its shape's; the
        // others are probed.
        let of_shape = |i: usize, shape: Option<usize>| {
            let shape = shape?;
            let (_, _, mask) = shapes.iter().find(|(k, s, _)| (*k, *s) == (i, shape))?;
            Some(mask.clone())
        };
        let mut masks: Vec<Option<Vec<bool>>> = unknowns
            .iter()
            .enumerate()
            .map(|(i, u)| {
                let kept = known.and_then(|k| (k.unknowns[i] == *u).then(|| k.masks[i].clone()));
                kept.or_else(|| of_shape(i, kernel_shapes[i]))
            })
            .collect();
        let todo: Vec<bool> = masks.iter().map(Option::is_none).collect();
        let probed = todo.iter().filter(|&&t| t).count();
        if probed > 0 {
            probe_kernels(sys, h, &todo, &mut masks);
        }
        let masks: Vec<Vec<bool>> = masks.into_iter().map(|m| m.unwrap_or_default()).collect();
        for (i, shape) in kernel_shapes.iter().enumerate() {
            if let (true, Some(shape)) = (todo[i], *shape) {
                shapes.push((i, shape, masks[i].clone()));
            }
        }
        BlockStructure {
            h,
            probed,
            unknowns,
            masks,
            shapes,
        }
    }
}

/// Probes the kernels marked in `todo` into `masks`: the union of the nonzeros at two generic
/// states (nodes rotated and moving, coordinates and multipliers nonzero), so that no entry
/// is missed because the initial configuration happens to be aligned with the axes. An EP
/// layout also serves static solves, whose tangents differ (e.g. a dead moment acts on the
/// f-triad): the pattern covers both.
fn probe_kernels(sys: &System, h: f64, todo: &[bool], masks: &mut [Option<Vec<bool>>]) {
    let n = sys.layout.n_unknowns();
    let wiggle = |k: f64| 0.37 + (k * 12.9898).sin();
    let modes: &[Option<f64>] = if sys.layout.ed() {
        &[None]
    } else {
        &[None, Some(0.7)]
    };
    for (trial, &statics) in (1..=2).flat_map(|t| modes.iter().map(move |m| (t, m))) {
        let t = trial as f64;
        let mut state = sys.initial.clone();
        for (a, node) in state.nodes.iter_mut().enumerate() {
            let k = 10.0 * t + a as f64;
            let tilt = V3([wiggle(k), wiggle(k + 0.1), wiggle(k + 0.2)]);
            node.r = exp_map(&tilt.scale_f(0.3)).mul_m(&node.r);
            node.x += tilt.scale_f(0.01 * sys.length_ref);
            node.v += tilt.scale_f(0.1);
            node.w += V3([wiggle(k + 0.3), wiggle(k + 0.4), wiggle(k + 0.5)]);
        }
        for (c, q) in state.coords.iter_mut().enumerate() {
            *q += 0.1 * wiggle(t + c as f64 + 0.6);
        }
        for (c, q) in state.coord_rates.iter_mut().enumerate() {
            *q += wiggle(t + c as f64 + 0.7);
        }
        let ctx = StepCtx {
            layout: sys.layout,
            h,
            t_i: 0.0,
            t_f: h,
            s: super::Integrator::scaling(sys, h),
            state: &state,
            gravity: sys.gravity,
            statics,
        };
        let y: Vec<f64> = (0..n)
            .map(|i| 1e-2 * wiggle(t * 100.0 + i as f64))
            .collect();
        let mut i = 0;
        for_each_kernel!(sys, |k| {
            if todo[i] {
                let found = k.structure(&ctx, &y);
                let mask = masks[i].get_or_insert_with(|| vec![false; found.len()]);
                mask.iter_mut().zip(found).for_each(|(x, b)| *x |= b);
            }
            i += 1;
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joints::Joint;
    use crate::math::layout::Scheme;

    /// After a sliding joint's window moves, the structure kept from before and completed
    /// by probing only the moved kernel is the structure probed afresh (a kernel whose mask
    /// depended on more than its unknowns, or a reuse off by one kernel, would break it),
    /// under both schemes.
    #[test]
    fn reprobing_a_moved_window_gives_the_fresh_structure() {
        let yaml = crate::testing::collar_on_free_beam_yaml(0.125);
        let model = crate::compile::from_yaml_str(&yaml).unwrap();
        for scheme in [Scheme::Ep, Scheme::Ed] {
            let mut sys = crate::compile::compile(&model, scheme).unwrap();
            let h = 1e-3;
            let before = BlockStructure::probe(&sys, h);
            let kernels = before.masks().len();
            assert_eq!(before.probed, kernels);
            let mut moved = false;
            for j in &mut sys.joints {
                if let Joint::Sliding(s) = j {
                    moved |= s.place_window(1.9);
                }
            }
            assert!(moved, "the window did not move");
            let kept = before.reprobe(&sys, h);
            assert_eq!(
                kept.probed, 1,
                "{scheme:?}: only the sliding joint is probed"
            );
            let fresh = BlockStructure::probe(&sys, h);
            assert_eq!(kept.unknowns, fresh.unknowns);
            assert_eq!(kept.masks, fresh.masks, "{scheme:?}");
            // Another step size is another structure's probe: nothing kept.
            assert_eq!(before.reprobe(&sys, 2e-3).probed, kernels);
        }
    }

    /// A sliding joint's window walked along the beam and back takes its shape's mask from
    /// the first window of that shape (`Kernel::structure_shape`), and that mask is the one
    /// probed afresh at every position: for each kind of sliding joint, on a straight beam
    /// and on the pre-twisted beam slider (a beam node as follower), under both schemes. A
    /// shape whose structure depended on where the window sits would fail here.
    #[test]
    fn a_moved_window_takes_its_shapes_mask_which_is_the_probed_one() {
        let straight = crate::testing::collar_on_free_beam_yaml(0.125);
        let twisted = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/beam_slider/twisted_case1.yaml"
        ))
        .unwrap();
        let models = ["sliding", "sliding_screw", "sliding_clamp"]
            .map(|kind| straight.replace("type: sliding,", &format!("type: {kind},")))
            .into_iter()
            .chain([twisted]);
        for yaml in models {
            let model = crate::compile::from_yaml_str(&yaml).unwrap();
            for scheme in [Scheme::Ep, Scheme::Ed] {
                let mut sys = crate::compile::compile(&model, scheme).unwrap();
                let h = 1e-3;
                let mut kept = BlockStructure::probe(&sys, h);
                let elements = match &sys.joints.iter().find_map(|j| j.as_sliding()) {
                    Some(s) => s.beam_elements(),
                    None => panic!("a sliding joint"),
                };
                let mut shapes = std::collections::BTreeSet::new();
                let mut probes = 0;
                let walk = (0..elements).chain((0..elements).rev());
                for e in walk {
                    for j in &mut sys.joints {
                        if let Joint::Sliding(s) = j {
                            s.place_window(e as f64 + 0.5);
                            shapes.insert(s.structure_shape());
                        }
                    }
                    kept = kept.reprobe(&sys, h);
                    probes += kept.probed;
                    let fresh = BlockStructure::probe(&sys, h);
                    assert_eq!(kept.masks, fresh.masks, "{scheme:?}, window at element {e}");
                }
                assert!(shapes.len() >= 2, "windows of {shapes:?} nodes only");
                assert!(
                    probes < shapes.len(),
                    "{scheme:?}: {probes} probes for windows of {} shapes",
                    shapes.len()
                );
            }
        }
    }
}
