//! The spec's colour-to-byte conversion ([`to_byte`]) as a table of the 255
//! radiances where the byte steps up, so a picture's bytes cost a short
//! search per channel instead of a `powf` and a `floor`.
//!
//! Why it gives the same bytes: [`to_byte`] is non-decreasing in the
//! radiance (a power with a positive exponent, a clamp and a rounding, each
//! monotone), so the byte of `c` is the number of steps at or below `c`. The
//! steps are found by bisection on [`to_byte`] itself, over the bit patterns
//! of the non-negative `f64`s (which order as the numbers do): each is the
//! smallest radiance whose byte reaches that step. Negative radiances and
//! NaN go to [`to_byte`] itself. The tests compare both
//! functions around every step and on random radiances.

use std::sync::OnceLock;

use crate::film::to_byte;
use crate::scene::Variant;

/// For each byte `b` in `1..=255`, at index `b`, the smallest radiance that
/// [`to_byte`] turns into `b` or more; index 0 is unused.
pub struct ByteTable {
    steps: [f64; 256],
    variant: Variant,
}

impl ByteTable {
    /// The table of `variant`'s conversion, computed once per process.
    pub fn of(variant: Variant) -> &'static ByteTable {
        static C2010: OnceLock<ByteTable> = OnceLock::new();
        static C2015: OnceLock<ByteTable> = OnceLock::new();
        let cell = match variant {
            Variant::Cornell2010 => &C2010,
            Variant::Cornell2015 => &C2015,
        };
        cell.get_or_init(|| ByteTable::new(variant))
    }

    fn new(variant: Variant) -> ByteTable {
        let mut steps = [f64::INFINITY; 256];
        let one = 1.0f64.to_bits();
        debug_assert_eq!(to_byte(1.0, variant), 255);
        for (b, step) in steps.iter_mut().enumerate().skip(1) {
            // Invariant: to_byte(lo) < b <= to_byte(hi).
            let (mut lo, mut hi) = (0u64, one);
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if usize::from(to_byte(f64::from_bits(mid), variant)) >= b {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            *step = f64::from_bits(hi);
        }
        ByteTable { steps, variant }
    }

    /// [`to_byte`]`(c, variant)` for this table's variant: the number of
    /// steps at or below `c`.
    #[inline]
    pub fn byte(&self, c: f64) -> u8 {
        // The steps describe the non-negative radiances only (a negative
        // base of the power is NaN, or +inf for -inf): the rest, and NaN,
        // take the conversion itself.
        if c.is_nan() || c < 0.0 {
            return to_byte(c, self.variant);
        }
        // Branch-free binary search: `at` is the largest index whose step
        // is <= c, every step from 1 to `at` is too.
        let mut at = 0usize;
        for half in [128, 64, 32, 16, 8, 4, 2, 1] {
            if self.steps[at + half] <= c {
                at += half;
            }
        }
        at as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const VARIANTS: [Variant; 2] = [Variant::Cornell2010, Variant::Cornell2015];

    #[test]
    fn equals_the_conversion_around_every_step() {
        for variant in VARIANTS {
            let table = ByteTable::of(variant);
            for b in 1..256 {
                let step = table.steps[b].to_bits();
                // 4096 bit patterns either side: far wider than any rounding
                // of the power could move a step.
                for bits in step - 4096..step + 4096 {
                    let c = f64::from_bits(bits);
                    assert_eq!(table.byte(c), to_byte(c, variant), "{variant:?} at {c:e}");
                }
            }
        }
    }

    #[test]
    fn equals_the_conversion_on_random_and_special_radiances() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let specials = [
            0.0,
            -0.0,
            -1.0,
            1.0,
            7.0,
            f64::MIN_POSITIVE,
            5e-324,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MAX,
        ];
        for variant in VARIANTS {
            let table = ByteTable::of(variant);
            for c in specials {
                assert_eq!(table.byte(c), to_byte(c, variant), "{variant:?} at {c:e}");
            }
            for _ in 0..200_000 {
                let r = next();
                // Uniform in [0, 1.25) and uniform over bit patterns.
                let uniform = (r >> 11) as f64 / (1u64 << 53) as f64 * 1.25;
                let any = f64::from_bits(next());
                for c in [uniform, any] {
                    assert_eq!(table.byte(c), to_byte(c, variant), "{variant:?} at {c:e}");
                }
            }
        }
    }
}
