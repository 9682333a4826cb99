//! Light sources.

use glam::DVec3;

/// A light as the scene describes it.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Emits from a point. 2010: no falloff; 2015: `1/r²` falloff.
    Point {
        /// Where the light is.
        position: DVec3,
        /// Its colour and strength.
        intensity: DVec3,
    },
    /// Infinitely far away: parallel light from one direction, no falloff.
    Directional {
        /// Unit direction *toward* the light.
        direction: DVec3,
        /// Its colour and strength.
        intensity: DVec3,
    },
}
