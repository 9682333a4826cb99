//! Tile geometry: how an image is cut into the bands a farm renders.

use crate::render::Region;

/// The region of tile `k` of `n`: the image cut into `n` horizontal bands
/// of whole rows, band `k` being rows `floor(k·h/n) .. floor((k+1)·h/n)`
/// (so band heights differ by at most one row). `None` unless
/// `k < n <= height` (every band must hold at least one row).
pub fn tile_region(width: u32, height: u32, k: u32, n: u32) -> Option<Region> {
    if n == 0 || k >= n || n > height || width == 0 {
        return None;
    }
    let row = |i: u32| (i as u64 * height as u64 / n as u64) as u32;
    Some(Region {
        x0: 0,
        y0: row(k),
        x1: width,
        y1: row(k + 1),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_every_row_once() {
        for h in 1..40 {
            for n in 1..=h {
                let mut next = 0;
                for k in 0..n {
                    let r = tile_region(7, h, k, n).unwrap();
                    assert_eq!(r.y0, next);
                    assert!(r.y1 > r.y0);
                    assert!(r.y1 - r.y0 <= h / n + 1);
                    next = r.y1;
                }
                assert_eq!(next, h);
            }
        }
        assert_eq!(tile_region(7, 5, 0, 6), None);
        assert_eq!(tile_region(7, 5, 3, 3), None);
        assert_eq!(tile_region(7, 5, 0, 0), None);
    }
}
