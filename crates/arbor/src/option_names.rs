//! Options named by one word (`--instancing nested`, `--bvol obb`): one
//! table of words and values serves parsing, its error and the name.

/// The value `word` names in `table`, or an error listing every word
/// ("unknown {what} 'w'; expected a, b or c").
pub(crate) fn parse<T: Copy>(word: &str, what: &str, table: &[(&str, T)]) -> Result<T, String> {
    if let Some(&(_, value)) = table.iter().find(|(w, _)| *w == word) {
        return Ok(value);
    }
    let words: Vec<&str> = table.iter().map(|(w, _)| *w).collect();
    let expected = match words.split_last() {
        Some((last, [])) => last.to_string(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    };
    Err(format!("unknown {what} '{word}'; expected {expected}"))
}

/// The word of `value` in `table` (every value has one).
pub(crate) fn name<T: PartialEq>(value: &T, table: &[(&'static str, T)]) -> &'static str {
    table
        .iter()
        .find(|(_, v)| v == value)
        .map_or("?", |(w, _)| w)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: &[(&str, u8)] = &[("one", 1), ("two", 2), ("three", 3)];

    #[test]
    fn words_parse_and_name_their_values() {
        assert_eq!(parse("two", "count", TABLE), Ok(2));
        assert_eq!(name(&3, TABLE), "three");
        assert_eq!(
            parse("four", "count", TABLE),
            Err("unknown count 'four'; expected one, two or three".to_string())
        );
        assert_eq!(
            parse("x", "word", &[("a", 0)]),
            Err("unknown word 'x'; expected a".to_string())
        );
    }
}
