//! LOD chains (`lod`): per primitive, coarser index lists over the same
//! vertices, built at load with meshoptimizer's simplifier (Garland and
//! Heckbert's quadric error metric, "Surface Simplification Using Quadric
//! Error Metrics", SIGGRAPH 1997, as meshoptimizer implements it), each
//! with the absolute object-space error the simplifier reports. Levels
//! halve the triangle count until the simplifier cannot (it stops on
//! borders and attribute seams) or [`MAX_LEVELS`] is reached. Built in
//! parallel over primitives.

use super::{Primitive, Scene};
use crate::view::lod::MAX_LEVELS;
use rayon::prelude::*;
use std::time::Instant;

/// One simplified level of a primitive.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// Triangle list indices into the primitive's own vertices.
    pub indices: Vec<u32>,
    /// Largest deviation from the original surface, object space.
    pub error: f32,
}

/// The chains of a scene's primitives.
#[derive(Clone, Debug, Default)]
pub struct Chains {
    /// Per primitive, its levels after the original (coarser first to
    /// last; may be empty).
    pub levels: Vec<Vec<Level>>,
    /// Wall-clock ms the build took.
    pub build_ms: f64,
}

impl Chains {
    /// Bytes of the extra index lists.
    pub fn index_bytes(&self) -> u64 {
        self.levels
            .iter()
            .flatten()
            .map(|l| 4 * l.indices.len() as u64)
            .sum()
    }

    /// Levels built in all.
    pub fn level_count(&self) -> usize {
        self.levels.iter().map(Vec::len).sum()
    }
}

/// Fewest triangles a level is simplified towards (below this the chain
/// stops: the drop step takes over).
pub const MIN_TRIANGLES: usize = 8;

/// The chain of one primitive.
pub fn chain(p: &Primitive) -> Vec<Level> {
    let mut out: Vec<Level> = Vec::new();
    let mut current = p.indices.clone();
    while out.len() + 1 < MAX_LEVELS && current.len() / 3 > MIN_TRIANGLES {
        let target = (current.len() / 2 / 3).max(MIN_TRIANGLES) * 3;
        let mut error = 0.0f32;
        // Simplify from the original each time (errors are then relative to
        // it, not accumulated), towards the halved count.
        let next = meshopt::simplify_decoder(
            &p.indices,
            &p.positions,
            target,
            f32::MAX,
            // Permissive: collapses may cross attribute seams (UV and normal
            // splits), without which many-part CAD and game meshes stop
            // after a level or two; the error stays the geometric one.
            meshopt::SimplifyOptions::ErrorAbsolute | meshopt::SimplifyOptions::Permissive,
            Some(&mut error),
        );
        // No progress (or a degenerate result): the chain ends.
        if next.is_empty() || next.len() * 10 > current.len() * 9 {
            break;
        }
        let error = error.max(out.last().map_or(0.0, |l| l.error));
        current = next.clone();
        out.push(Level {
            indices: next,
            error,
        });
    }
    out
}

/// The chains of every primitive of `scene`.
pub fn build(scene: &Scene) -> Chains {
    let t = Instant::now();
    let levels = scene.primitives.par_iter().map(chain).collect();
    Chains {
        levels,
        build_ms: t.elapsed().as_secs_f64() * 1e3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes;

    #[test]
    fn a_fine_cylinder_gets_a_chain_of_fewer_triangles_and_growing_error() {
        let p = shapes::cylinder(1.0, 2.0, 256, 0);
        let levels = chain(&p);
        assert!(levels.len() >= 2, "{} levels", levels.len());
        let mut tris = p.triangles();
        let mut err = 0.0;
        for l in &levels {
            assert!(l.indices.len() / 3 < tris);
            assert!(l.error >= err && l.error.is_finite());
            assert!(l.indices.iter().all(|&i| (i as usize) < p.positions.len()));
            tris = l.indices.len() / 3;
            err = l.error;
        }
        // Coarser levels deviate, but within the cylinder's size.
        assert!(err > 0.0 && err < 2.0, "{err}");
    }

    /// Twelve triangles are the fewest a closed box has: any coarser level
    /// deviates, and must say so.
    #[test]
    fn a_box_loses_triangles_only_with_an_error() {
        for l in chain(&shapes::cuboid([1.0, 1.0, 1.0], 0)) {
            assert!(l.indices.len() / 3 < 12);
            assert!(l.error > 0.1, "{}", l.error);
        }
    }
}
