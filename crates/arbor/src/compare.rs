//! Comparing two 8-bit RGB images: how close a render is to a reference.

/// Agreement between two images of the same size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Peak signal-to-noise ratio in dB (infinite for identical images).
    pub psnr: f64,
    /// Mean absolute difference per channel value, in 0..255 units.
    pub mean_abs: f64,
    /// Largest absolute difference of any channel value.
    pub max_abs: u8,
    /// Fraction of channel values that differ by at most 2.
    pub within_2: f64,
    /// Fraction of pixels whose three channels are identical.
    pub identical_pixels: f64,
}

/// Compares `a` and `b`, both RGB8 buffers of the same length (3 bytes a
/// pixel); `None` when the lengths differ or are empty.
pub fn compare_rgb8(a: &[u8], b: &[u8]) -> Option<Comparison> {
    if a.len() != b.len() || a.is_empty() || !a.len().is_multiple_of(3) {
        return None;
    }
    let mut sq = 0u64;
    let mut abs = 0u64;
    let mut max = 0u8;
    let mut within = 0usize;
    for (&x, &y) in a.iter().zip(b) {
        let d = x.abs_diff(y);
        sq += d as u64 * d as u64;
        abs += d as u64;
        max = max.max(d);
        within += (d <= 2) as usize;
    }
    let identical = a
        .chunks_exact(3)
        .zip(b.chunks_exact(3))
        .filter(|(p, q)| p == q)
        .count();
    let n = a.len() as f64;
    let mse = sq as f64 / n;
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    };
    Some(Comparison {
        psnr,
        mean_abs: abs as f64 / n,
        max_abs: max,
        within_2: within as f64 / n,
        identical_pixels: identical as f64 / (n / 3.0),
    })
}

/// The per-channel absolute difference of `a` and `b`, multiplied by `gain`
/// and clamped, so that small differences become visible.
pub fn difference_image(a: &[u8], b: &[u8], gain: u32) -> Vec<u8> {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| (x.abs_diff(y) as u32 * gain).min(255) as u8)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_and_different() {
        let a = [10u8, 20, 30, 40, 50, 60];
        let c = compare_rgb8(&a, &a).unwrap();
        assert_eq!(
            (c.psnr, c.max_abs, c.within_2, c.identical_pixels),
            (f64::INFINITY, 0, 1.0, 1.0)
        );
        let b = [10u8, 20, 33, 40, 50, 60];
        let c = compare_rgb8(&a, &b).unwrap();
        assert_eq!(c.max_abs, 3);
        assert!((c.within_2 - 5.0 / 6.0).abs() < 1e-12);
        assert_eq!(c.identical_pixels, 0.5);
        // MSE = 9/6 = 1.5 -> 10 log10(65025 / 1.5)
        assert!((c.psnr - 10.0 * (65025.0f64 / 1.5).log10()).abs() < 1e-9);
        assert!(compare_rgb8(&a, &a[..3]).is_none());
        assert_eq!(difference_image(&a, &b, 16)[2], 48);
    }
}
