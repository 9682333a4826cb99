//! Directed rounding from `f64` to `f32`: the one place where an exact
//! value becomes the `f32` bound on its side that conservative culling needs.

/// The largest `f32` not above `x` (`x` itself when it is an `f32`).
#[inline]
pub fn f32_at_or_below(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x {
        f.next_down()
    } else {
        f
    }
}

/// The smallest `f32` not below `x` (`x` itself when it is an `f32`).
#[inline]
pub fn f32_at_or_above(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x {
        f.next_up()
    } else {
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounds_to_the_neighbouring_floats_on_each_side() {
        let third = 1.0f64 / 3.0;
        let (lo, hi) = (f32_at_or_below(third), f32_at_or_above(third));
        assert!(f64::from(lo) < third && third < f64::from(hi));
        assert_eq!(lo.next_up(), hi);
        // Exactly representable values are kept on both sides.
        assert_eq!((f32_at_or_below(0.5), f32_at_or_above(0.5)), (0.5, 0.5));
        assert_eq!(f32_at_or_above(-third), -lo);
        // Beyond f32's range: infinities on the far side, MAX on the near one.
        assert_eq!(f32_at_or_above(1e300), f32::INFINITY);
        assert_eq!(f32_at_or_below(1e300), f32::MAX);
    }
}
