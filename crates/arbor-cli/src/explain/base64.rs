//! Base64 for the data embedded in the page (the picture, the heatmaps,
//! the per-pixel counts): standard RFC 4648 with padding, by the `base64`
//! crate, and the per-pixel counts packed in their narrowest integer type.

/// `bytes` in standard base64 with padding.
pub fn encode(bytes: &[u8]) -> String {
    ::base64::encode(bytes)
}

/// The narrowest unsigned type that holds every value up to `max`, by its
/// name in the page data (`u8`, `u16` or `u32`), and its size in bytes.
pub fn element_for(max: u32) -> (&'static str, usize) {
    if max <= u32::from(u8::MAX) {
        ("u8", 1)
    } else if max <= u32::from(u16::MAX) {
        ("u16", 2)
    } else {
        ("u32", 4)
    }
}

/// `values` as little-endian elements of `size` bytes (from
/// [`element_for`] of their maximum) in base64: counts per pixel are mostly
/// small, so the page carries a quarter of the bytes `u32`s would take.
pub fn encode_narrow(values: &[u32], size: usize) -> String {
    let bytes: Vec<u8> = values
        .iter()
        .flat_map(|v| v.to_le_bytes().into_iter().take(size))
        .collect();
    encode(&bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn narrow_elements_keep_every_value() {
        assert_eq!(element_for(255), ("u8", 1));
        assert_eq!(element_for(256), ("u16", 2));
        assert_eq!(element_for(65_536), ("u32", 4));
        // 0x0102 as u16 little-endian is [2, 1]; as u8s of 255 and 7: [255, 7].
        assert_eq!(encode_narrow(&[0x0102], 2), encode(&[2, 1]));
        assert_eq!(encode_narrow(&[255, 7], 1), encode(&[255, 7]));
        assert_eq!(encode_narrow(&[0x0102_0304], 4), encode(&[4, 3, 2, 1]));
    }

    #[test]
    fn matches_the_rfc_examples() {
        // RFC 4648, section 10.
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, coded) in cases {
            assert_eq!(encode(plain.as_bytes()), coded, "{plain:?}");
        }
    }

    #[test]
    fn u32s_are_little_endian() {
        // 1 = 01 00 00 00, 258 = 02 01 00 00.
        assert_eq!(
            encode_narrow(&[1, 258], 4),
            encode(&[1, 0, 0, 0, 2, 1, 0, 0])
        );
        assert_eq!(encode(&[255, 255, 255]), "////");
    }
}
