//! The spec's colour-to-byte conversion ([`to_byte`]) as tables, so a
//! picture's bytes cost a lookup and one comparison per channel instead of
//! a `powf` and a `floor`.
//!
//! Why it gives the same bytes: [`to_byte`] is non-decreasing in the
//! radiance (a power with a positive exponent, a clamp and a rounding, each
//! monotone), so it is described by its 255 *steps*, the smallest radiance
//! of each byte, found by bisection on [`to_byte`] itself over the bit
//! patterns of the non-negative `f64`s (which order as the numbers do).
//! Radiances in `[2^-21, 1)` are cut into buckets by their exponent and top
//! 8 mantissa bits; a bucket spans less than half a byte, so it holds at
//! most one step (checked as the tables are made), and the byte is the
//! bucket's first byte, plus one from that step on. Below `2^-21` (under
//! the first step) the byte is 0, from 1 on it is 255; negative radiances
//! and NaN go to [`to_byte`] itself. The tests compare both functions
//! around every step and on random radiances.

use std::sync::OnceLock;

use crate::variant::Variant;

/// The smallest radiance with a bucket, `2^-21`.
const LOW: f64 = 1.0 / (1u64 << 21) as f64;
/// Mantissa bits that pick a bucket within an octave.
const BUCKET_BITS: u32 = 8;
/// Buckets over `[LOW, 1)`: 21 octaves of `2^BUCKET_BITS`.
const BUCKETS: usize = 21 << BUCKET_BITS;

/// Low bits of an `f64` below a bucket's exponent and mantissa bits.
const SHIFT: u32 = 52 - BUCKET_BITS;

/// The bucket of a radiance in `[LOW, 1)`.
#[inline]
fn bucket(c: f64) -> usize {
    ((c.to_bits() >> SHIFT) - (LOW.to_bits() >> SHIFT)) as usize
}

/// The smallest radiance of bucket `k` (`k == BUCKETS` gives 1).
fn bucket_start(k: usize) -> f64 {
    f64::from_bits(((LOW.to_bits() >> SHIFT) + k as u64) << SHIFT)
}

/// The spec's colour-to-byte conversion (§7): gamma 1/2.2 on the averaged
/// linear value, clamped; 2010 rounds the gamma-corrected value to `f32`
/// first and scales in `f32`, as the Java framework did. NaN becomes 0.
pub fn to_byte(c: f64, variant: Variant) -> u8 {
    let g = c.powf(1.0 / 2.2).clamp(0.0, 1.0);
    if g.is_nan() {
        return 0;
    }
    let scaled = match variant {
        Variant::Cornell2010 => (255.0f32 * g as f32) as f64,
        Variant::Cornell2015 => 255.0 * g,
    };
    (scaled + 0.5).floor() as u8
}

/// One variant's conversion: its steps and its buckets' first bytes.
pub struct ByteTable {
    /// At index `b` in `1..=255`, the smallest radiance that [`to_byte`]
    /// turns into `b` or more; index 0 unused, index 256 +inf.
    steps: [f64; 257],
    /// Per bucket, the byte of its smallest radiance.
    first: Box<[u8; BUCKETS]>,
    variant: Variant,
}

impl ByteTable {
    /// The tables of `variant`'s conversion, made once per process.
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
        let mut steps = [f64::INFINITY; 257];
        let one = 1.0f64.to_bits();
        assert_eq!(to_byte(1.0, variant), 255);
        for (b, step) in steps.iter_mut().enumerate().take(256).skip(1) {
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
        assert!(steps[1] > LOW, "the first step lies below the buckets");
        let mut first = Box::new([0u8; BUCKETS]);
        // Buckets in increasing order: `b` only grows.
        let mut b = 0;
        for (k, byte) in first.iter_mut().enumerate() {
            let (start, end) = (bucket_start(k), bucket_start(k + 1));
            while steps[b + 1] <= start {
                b += 1;
            }
            let next_but_one = steps.get(b + 2).copied().unwrap_or(f64::INFINITY);
            assert!(next_but_one >= end, "two steps in the bucket of {start:e}");
            *byte = b as u8;
        }
        ByteTable {
            steps,
            first,
            variant,
        }
    }

    /// [`to_byte`]`(c, variant)` for this table's variant.
    #[inline]
    pub fn byte(&self, c: f64) -> u8 {
        if (LOW..1.0).contains(&c) {
            let b = self.first[bucket(c)];
            return b + u8::from(c >= self.steps[usize::from(b) + 1]);
        }
        if c >= 1.0 {
            255
        } else if c >= 0.0 {
            0
        } else {
            // Negative (the power's base: NaN, or +inf for -inf) or NaN.
            to_byte(c, self.variant)
        }
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
