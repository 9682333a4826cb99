//! Parsing the text of value elements the way the course's Java parser
//! does (spec §2.4), with errors instead of Java's exceptions.

use glam::DVec3;

/// A Java `Double.valueOf`-style number: surrounding whitespace trimmed,
/// forms like `.3`, `-.8`, `1.`, `8.0E-6` and a trailing `d`/`f` type suffix
/// accepted. Non-finite values are rejected.
pub fn parse_number(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let body = t
        .strip_suffix(['d', 'D', 'f', 'F'])
        .filter(|b| b.ends_with(|c: char| c.is_ascii_digit() || c == '.'))
        .unwrap_or(t);
    // Rust also accepts "inf" and "nan", which Java spells differently and
    // which no scene may use; only plain decimal forms get through.
    let plain = !body.is_empty()
        && body
            .chars()
            .all(|c| c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'e' | 'E'));
    match body.parse::<f64>() {
        Ok(v) if plain && v.is_finite() => Ok(v),
        Ok(_) if plain => Err(format!("number '{t}' is out of range")),
        _ => Err(format!("expected a number, found '{t}'")),
    }
}

/// An integer (trimmed, unlike Java, as the spec recommends).
pub fn parse_int(text: &str) -> Result<i64, String> {
    let t = text.trim();
    t.parse::<i64>()
        .map_err(|_| format!("expected a whole number, found '{t}'"))
}

/// Exactly three whitespace-separated numbers.
pub fn parse_vector(text: &str) -> Result<DVec3, String> {
    let [x, y, z] = words(text, "numbers")?;
    Ok(DVec3::new(
        parse_number(x)?,
        parse_number(y)?,
        parse_number(z)?,
    ))
}

/// Exactly two whole numbers (`<image>W H</image>`).
pub fn parse_size(text: &str) -> Result<(i64, i64), String> {
    let [width, height] = words(text, "whole numbers (width height)")?;
    Ok((parse_int(width)?, parse_int(height)?))
}

/// The whitespace-separated words of `text`, exactly `N` of them (`what`
/// names them in the error).
fn words<'a, const N: usize>(text: &'a str, what: &str) -> Result<[&'a str; N], String> {
    let parts: Vec<&str> = text.split_whitespace().collect();
    parts.try_into().map_err(|parts: Vec<&str>| {
        format!(
            "expected {N} {what}, found {} in '{}'",
            parts.len(),
            text.trim()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn java_number_forms() {
        for (s, v) in [
            (" 1 ", 1.0),
            (".3", 0.3),
            ("-.8", -0.8),
            ("1.", 1.0),
            ("8.0E-6", 8.0e-6),
            ("+2", 2.0),
            ("2.5f", 2.5),
            ("3d", 3.0),
        ] {
            assert_eq!(parse_number(s), Ok(v), "{s}");
        }
        for s in [
            "", "abc", "1,5", "inf", "NaN", "Infinity", "1e999", "0x10", "f",
        ] {
            assert!(parse_number(s).is_err(), "{s}");
        }
    }

    #[test]
    fn vectors_need_three() {
        assert_eq!(parse_vector("1 2\t3\r\n"), Ok(DVec3::new(1.0, 2.0, 3.0)));
        assert!(parse_vector("1 2")
            .unwrap_err()
            .contains("expected 3 numbers, found 2"));
        assert!(parse_vector("1 2 3 4").is_err());
        assert!(parse_vector("1 x 3").is_err());
    }

    #[test]
    fn sizes_and_ints() {
        assert_eq!(parse_size(" 300\n 200 "), Ok((300, 200)));
        assert!(parse_size("300").is_err());
        assert!(parse_int("1.5").is_err());
        assert_eq!(parse_int(" 16 "), Ok(16));
    }
}
