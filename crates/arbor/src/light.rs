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
    /// A point light shining into a cone (glTF's spot light), falling off
    /// as `1/r²` and smoothly from full strength inside `cos_inner` to none
    /// outside `cos_outer` ([`spot_falloff`]).
    Spot {
        /// Where the light is.
        position: DVec3,
        /// Unit direction the cone opens along.
        direction: DVec3,
        /// Its colour and strength on the axis.
        intensity: DVec3,
        /// Cosine of the angle from the axis within which it is at full strength.
        cos_inner: f64,
        /// Cosine of the angle from the axis beyond which it gives no light.
        cos_outer: f64,
    },
}

/// A spot light's strength in a direction at cosine `cos` from its axis:
/// 1 inside the inner cone, 0 outside the outer one, and between them the
/// square of a linear ramp in the cosine (the smooth falloff the glTF
/// specification suggests).
pub fn spot_falloff(cos: f64, cos_inner: f64, cos_outer: f64) -> f64 {
    // A cone with no soft edge still needs a ramp to divide by.
    let width = (cos_inner - cos_outer).max(1e-3);
    let ramp = ((cos - cos_outer) / width).clamp(0.0, 1.0);
    ramp * ramp
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_falloff_is_full_inside_and_none_outside() {
        let (inner, outer) = (0.3f64.cos(), 0.5f64.cos());
        assert_eq!(spot_falloff(1.0, inner, outer), 1.0);
        assert_eq!(spot_falloff(0.3f64.cos(), inner, outer), 1.0);
        assert_eq!(spot_falloff(0.6f64.cos(), inner, outer), 0.0);
        let mid = spot_falloff(0.4f64.cos(), inner, outer);
        assert!(mid > 0.0 && mid < 1.0, "{mid}");
        // Monotonic toward the axis.
        assert!(spot_falloff(0.35f64.cos(), inner, outer) > mid);
    }
}
