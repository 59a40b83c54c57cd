//! The line protocol between `patchvis conformance` and a reader under test
//! (tests/conformance/README.md, "Testing another reader"): the request lines, and a reply
//! read as `key value` pairs.
//!
//! A query's reply is the right-hand side of a dump's `query` line, e.g.
//! `inside false band 2 shells [1,2] views [0,2,4] inner [0,2,4] patches [0,3]`: each key
//! followed by one word (a list is written without spaces). Only `inside` and `patches` are
//! required; every other key a reader gives is compared where the expectation has it.

/// The protocol's version, the first request's argument (`hello 1`).
pub const VERSION: u32 = 1;

/// The keys a query's reply may hold, in the order a dump writes them.
pub const QUERY_KEYS: [&str; 6] = ["inside", "band", "shells", "views", "inner", "patches"];

/// A reply or an expectation read as `key value` pairs, in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fields(pub Vec<(String, String)>);

impl Fields {
    /// Reads `key value key value …`; an error if a key has no value or repeats, or one of
    /// `required` is missing.
    pub fn parse(text: &str, required: &[&str]) -> Result<Fields, String> {
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        if !words.len().is_multiple_of(2) {
            return Err(format!("`{text}`: expected `key value` pairs"));
        }
        let mut pairs: Vec<(String, String)> = Vec::new();
        for pair in words.chunks(2) {
            if pairs.iter().any(|(k, _)| k == pair[0]) {
                return Err(format!("`{text}`: `{}` given twice", pair[0]));
            }
            pairs.push((pair[0].to_string(), pair[1].to_string()));
        }
        let fields = Fields(pairs);
        if let Some(missing) = required.iter().find(|k| fields.get(k).is_none()) {
            return Err(format!("`{text}`: expected a `{missing}` field"));
        }
        Ok(fields)
    }

    /// The value of `key`, if given.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The first field of `self` whose value differs from `expected`'s, as
    /// `(key, expected, got)`; keys `expected` does not have are not compared. A key neither
    /// side knows is an error of the reply.
    pub fn first_difference<'f>(
        &'f self,
        expected: &'f Fields,
    ) -> Result<Option<(&'f str, &'f str, &'f str)>, String> {
        for (key, got) in &self.0 {
            if !QUERY_KEYS.contains(&key.as_str()) {
                return Err(format!("unknown field `{key}`"));
            }
            if let Some(want) = expected.get(key)
                && want != got
            {
                return Ok(Some((key, want, got)));
            }
        }
        Ok(None)
    }
}

/// A list of patches as the protocol writes it: `[0,3,7]`.
pub fn list(items: impl IntoIterator<Item = u32>) -> String {
    let items: Vec<String> = items.into_iter().map(|p| p.to_string()).collect();
    format!("[{}]", items.join(","))
}

/// Reads `[0,3,7]` back; `None` if malformed.
pub fn parse_list(text: &str) -> Option<Vec<u32>> {
    let inner = text.strip_prefix('[')?.strip_suffix(']')?;
    if inner.is_empty() {
        return Some(Vec::new());
    }
    inner.split(',').map(|p| p.parse().ok()).collect()
}

/// A coordinate as the dumps and the protocol write it: the shortest decimal that reads back
/// as the same binary32, or `inf`, `-inf`, `NaN`.
pub fn parse_number(text: &str) -> Option<f32> {
    match text {
        "inf" => Some(f32::INFINITY),
        "-inf" => Some(f32::NEG_INFINITY),
        _ => text.parse().ok(),
    }
}

/// `X,Y,Z` as three binary32 numbers.
pub fn parse_point(text: &str) -> Option<[f32; 3]> {
    let mut parts = text.split(',').map(parse_number);
    let point = [parts.next()??, parts.next()??, parts.next()??];
    parts.next().is_none().then_some(point)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_parse_and_compare() {
        let want = Fields::parse("inside false views [0,2,4] patches [0,3]", &[]).unwrap();
        let got = Fields::parse("inside false band 1 patches [0]", &["inside", "patches"]);
        let got = got.unwrap();
        assert_eq!(
            got.first_difference(&want).unwrap(),
            Some(("patches", "[0,3]", "[0]"))
        );
        let same = Fields::parse("patches [0,3] inside false", &[]).unwrap();
        assert_eq!(same.first_difference(&want).unwrap(), None);
        assert!(Fields::parse("inside", &[]).is_err());
        assert!(Fields::parse("inside true inside false", &[]).is_err());
        assert!(Fields::parse("inside true", &["patches"]).is_err());
        let odd = Fields::parse("colour red", &[]).unwrap();
        assert!(odd.first_difference(&want).is_err());
    }

    #[test]
    fn lists_and_points_round_trip() {
        assert_eq!(list([0, 3, 7]), "[0,3,7]");
        assert_eq!(parse_list("[0,3,7]"), Some(vec![0, 3, 7]));
        assert_eq!(parse_list("[]"), Some(vec![]));
        assert_eq!(parse_list("[0, 3]"), None);
        assert_eq!(
            parse_point("1,-inf,2.5"),
            Some([1.0, f32::NEG_INFINITY, 2.5])
        );
        assert_eq!(parse_point("1,2"), None);
        assert_eq!(parse_point("1,2,3,4"), None);
        let big = parse_point("1000000000000000000000000000000,0,0").unwrap();
        assert_eq!(big[0], 1e30);
    }
}
