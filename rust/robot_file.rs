//! The rules every robot-file reader follows (planar and spatial): one TOML
//! parse into a table (or a table built from data: the same checks follow),
//! read with errors that name the field by its path, fixed-size arrays
//! that refuse extra or missing elements, and the checks of the name,
//! lengths, masses and tensions. Nothing is truncated, clamped or dropped:
//! what cannot be taken whole is refused with the field and the problem.

use crate::error::{CdsmError, Result};
use serde::de::{Deserialize, Deserializer, Error as _};

/// Largest magnitude of any length in a robot file (m). Past a kilometre a
/// description is not a serpentine arm (a file in the wrong unit, or a
/// typo), and the squares in the cable lengths would lose all precision.
pub const MAX_LENGTH: f64 = 1.0e3;

/// A robot-file error on `field`.
pub(crate) fn bad(field: String, problem: impl Into<String>) -> CdsmError {
    CdsmError::Robot {
        field,
        problem: problem.into(),
    }
}

/// A robot file's TOML as a table. A syntax error (a duplicate key, a
/// missing bracket) names the key at the error and its line.
pub(crate) fn toml_table(text: &str) -> Result<toml::Table> {
    text.parse().map_err(|e: toml::de::Error| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
        // the key under the error, when the error points at one
        let key = e.span().and_then(|s| {
            let t = text.get(s.clone())?.trim();
            let ident = !t.is_empty()
                && t.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c));
            ident.then(|| t.to_string())
        });
        let field = match (key, line) {
            (Some(k), _) => k,
            (None, Some(l)) => format!("<line {l}>"),
            (None, None) => "<file>".to_string(),
        };
        let problem = e.message().trim().replace('\n', " ");
        match line {
            Some(l) => bad(field, format!("{problem} (line {l})")),
            None => bad(field, problem),
        }
    })
}

/// A robot file's table (parsed from TOML, or built from data) as `T`; a
/// type or shape error names the field by its path
/// (`linkage[0].thickness`).
pub(crate) fn from_table<T: serde::de::DeserializeOwned>(table: toml::Table) -> Result<T> {
    serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
        let path = e.path().to_string();
        let field = if path.is_empty() || path == "." {
            "<file>".to_string()
        } else {
            path
        };
        bad(field, e.into_inner().to_string().trim().replace('\n', " "))
    })
}

/// Whether XML 1.0 allows `c` in a document (its `Char` production: tab,
/// line feed, carriage return, U+0020-U+D7FF, U+E000-U+FFFD,
/// U+10000-U+10FFFF); the others (the other C0 controls, U+FFFE, U+FFFF)
/// cannot appear in well-formed XML, not even escaped.
fn xml_char(c: char) -> bool {
    matches!(c as u32, 0x9 | 0xA | 0xD | 0x20..=0xD7FF | 0xE000..=0xFFFD | 0x10000..=0x10FFFF)
}

/// A robot's `name` (`None`: "unnamed"): any Unicode that XML allows (the
/// MJCF and URDF exports carry it as an attribute); a character XML forbids
/// is refused, named by its code point and position.
pub(crate) fn robot_name(name: Option<String>) -> Result<String> {
    let Some(name) = name else {
        return Ok("unnamed".to_string());
    };
    if let Some((i, c)) = name.chars().enumerate().find(|(_, c)| !xml_char(*c)) {
        return Err(bad(
            "name".into(),
            format!(
                "character U+{:04X} (character {} of {name:?}) is not allowed: XML forbids it, so \
                 no MJCF or URDF could carry the name",
                c as u32,
                i + 1
            ),
        ));
    }
    Ok(name)
}

/// A fixed-size array of numbers in a robot file: exactly `N` of them
/// (serde's arrays would take the first `N` of a longer list).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Exact<const N: usize>(pub [f64; N]);

impl<'de, const N: usize> Deserialize<'de> for Exact<N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        let got = v.len();
        <[f64; N]>::try_from(v)
            .map(Exact)
            .map_err(|_| D::Error::invalid_length(got, &format!("exactly {N} numbers").as_str()))
    }
}

/// `v` positive and finite (`unit` names what it is: Pa, N, ...).
pub(crate) fn positive(field: String, v: f64, unit: &str) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(bad(
            field,
            format!("must be positive and finite ({unit}), got {v}"),
        ))
    }
}

/// `v` as a length (m): positive, finite and at most [`MAX_LENGTH`].
pub(crate) fn positive_length(field: String, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 && v <= MAX_LENGTH {
        Ok(v)
    } else {
        Err(bad(
            field,
            format!("must be a positive length up to {MAX_LENGTH} m (SI units: metres), got {v}"),
        ))
    }
}

/// `v` finite and >= 0 (`unit` names what it is: kg, N, m, ...).
pub(crate) fn non_negative(field: String, v: f64, unit: &str) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(bad(
            field,
            format!("must be finite and >= 0 ({unit}), got {v}"),
        ))
    }
}

/// A point or vector of lengths (m): every component finite and within
/// ±[`MAX_LENGTH`].
pub(crate) fn coordinates<const N: usize>(field: String, v: [f64; N]) -> Result<[f64; N]> {
    if v.iter().all(|x| x.is_finite() && x.abs() <= MAX_LENGTH) {
        Ok(v)
    } else {
        Err(bad(
            field,
            format!("every coordinate must be finite and within ±{MAX_LENGTH} m, got {v:?}"),
        ))
    }
}

/// Joint limits `[lo, hi]` (rad): finite with `lo < hi`; `None` gives ±π.
pub(crate) fn joint_limits(field: String, v: Option<Exact<2>>) -> Result<[f64; 2]> {
    let lim = v.map_or([-std::f64::consts::PI, std::f64::consts::PI], |e| e.0);
    if lim[0].is_finite() && lim[1].is_finite() && lim[0] < lim[1] {
        Ok(lim)
    } else {
        Err(bad(
            field,
            format!("must be finite [lo, hi] with lo < hi (rad), got {lim:?}"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Deserialize, Debug)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct File {
        n: Option<usize>,
        g: Option<Exact<2>>,
        link: Vec<Link>,
    }

    #[derive(Deserialize, Debug)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Link {
        thickness: f64,
        holes: Option<Vec<Exact<3>>>,
    }

    fn parse_toml<T: serde::de::DeserializeOwned>(text: &str) -> Result<T> {
        from_table(toml_table(text)?)
    }

    fn field_of(text: &str) -> (String, String) {
        match parse_toml::<File>(text) {
            Err(CdsmError::Robot { field, problem }) => (field, problem),
            other => panic!("expected a robot error, got {other:?}"),
        }
    }

    #[test]
    fn errors_name_the_field_not_the_value() {
        let (f, p) = field_of("n = 3.0\n[[link]]\nthickness = 0.1\n");
        assert_eq!(f, "n", "{p}");
        let (f, p) = field_of("[[link]]\nthickness = 0.1\n[[link]]\nthickness = true\n");
        assert_eq!(f, "link[1].thickness", "{p}");
        assert!(p.contains("boolean"), "{p}");
        let (f, p) = field_of("n = 3\nn = 3\n[[link]]\nthickness = 0.1\n");
        assert_eq!(f, "n", "{p}");
        assert!(p.contains("duplicate") && p.contains("line 2"), "{p}");
    }

    #[test]
    fn fixed_arrays_take_exactly_their_size() {
        let (f, p) = field_of("g = [0.0, -9.8, 5.0]\n[[link]]\nthickness = 0.1\n");
        assert_eq!(f, "g", "{p}");
        assert!(p.contains("exactly 2") && p.contains('3'), "{p}");
        let (f, p) = field_of("[[link]]\nthickness = 0.1\nholes = [[0.0, 1.0, 2.0], [1.0, 2.0]]\n");
        assert_eq!(f, "link[0].holes[1]", "{p}");
        let ok: File = parse_toml("g = [0.0, -9.8]\n[[link]]\nthickness = 0.1\n").unwrap();
        assert_eq!(ok.g.unwrap().0, [0.0, -9.8]);
    }

    #[test]
    fn names_with_characters_xml_forbids_are_refused() {
        for (name, code) in [
            ("a\u{0}b", "U+0000"),
            ("\u{1}", "U+0001"),
            ("arm \u{1b}[31m", "U+001B"),
            ("x\u{B}", "U+000B"),
            ("\u{FFFE}", "U+FFFE"),
            ("y\u{FFFF}", "U+FFFF"),
        ] {
            match robot_name(Some(name.into())) {
                Err(CdsmError::Robot { field, problem }) => {
                    assert_eq!(field, "name");
                    assert!(problem.contains(code), "{problem}");
                }
                other => panic!("{name:?}: expected a robot error, got {other:?}"),
            }
        }
        let fine =
            "arm \u{1F4AA} \"q\" \\ \t\n\r\u{7f}\u{85}\u{D7FF}\u{E000}\u{FFFD}\u{10000}\u{10FFFF}";
        assert_eq!(robot_name(Some(fine.into())).unwrap(), fine);
        assert_eq!(robot_name(None).unwrap(), "unnamed");
    }

    #[test]
    fn lengths_past_a_kilometre_are_refused() {
        assert!(positive_length("l".into(), 1e308).is_err());
        assert!(positive_length("l".into(), 0.02).is_ok());
        assert!(coordinates("p".into(), [0.0, 1e308, 0.0]).is_err());
    }
}
