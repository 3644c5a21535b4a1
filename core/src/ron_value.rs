//! A RON value, as written after `--set path=`, turned into the JSON value serde gives
//! the same data, keeping the names of enum variants (which `ron`'s self-describing
//! deserializer drops):
//!
//! | RON | JSON (serde's external tagging) |
//! |---|---|
//! | `Periodic` | `"Periodic"` |
//! | `Uniform((1.0, 0.0))` | `{"Uniform": [1.0, 0.0]}` |
//! | `Disk(center: (1.0, 2.0), radius: 0.1)` | `{"Disk": {"center": [1.0, 2.0], "radius": 0.1}}` |
//! | `(model: "pcg")` | `{"model": "pcg"}` |
//! | `Some(x)` / `None` | `x` / `null` |
//! | `(1, 2)`, `[1, 2]` | `[1, 2]` |

use serde_json::{Map, Number, Value};

/// Parses `text` as one RON value; the error says where it stopped and why.
/// Brackets nested deeper than [`crate::input::MAX_NESTING`] are refused before parsing,
/// so the parser's recursion is bounded.
pub fn parse(text: &str) -> Result<Value, String> {
    crate::input::check_nesting(text)?;
    let mut p = Parser { s: text.as_bytes(), i: 0 };
    let v = p.value()?;
    p.skip();
    if p.i < p.s.len() {
        return Err(format!("unexpected `{}` at column {}", p.rest(), p.i + 1));
    }
    Ok(v)
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn rest(&self) -> String {
        String::from_utf8_lossy(&self.s[self.i..]).chars().take(12).collect()
    }
    fn skip(&mut self) {
        while self.i < self.s.len() && (self.s[self.i] as char).is_whitespace() {
            self.i += 1;
        }
    }
    fn peek(&mut self) -> Option<u8> {
        self.skip();
        self.s.get(self.i).copied()
    }
    fn expect(&mut self, c: u8) -> Result<(), String> {
        if self.peek() == Some(c) {
            self.i += 1;
            Ok(())
        } else {
            Err(format!("expected `{}` at column {}", c as char, self.i + 1))
        }
    }
    fn identifier(&mut self) -> Option<String> {
        self.skip();
        let start = self.i;
        while self.i < self.s.len() && (self.s[self.i].is_ascii_alphanumeric() || self.s[self.i] == b'_') {
            self.i += 1;
        }
        (self.i > start && !self.s[start].is_ascii_digit())
            .then(|| String::from_utf8_lossy(&self.s[start..self.i]).into_owned())
            .or_else(|| {
                self.i = start;
                None
            })
    }

    fn value(&mut self) -> Result<Value, String> {
        match self.peek() {
            None => Err("a value is missing".into()),
            Some(b'"') => self.string().map(Value::String),
            Some(b'[') => {
                self.i += 1;
                self.sequence(b']').map(Value::Array)
            }
            Some(b'(') => {
                self.i += 1;
                self.parenthesised()
            }
            Some(c) if c == b'-' || c == b'+' || c == b'.' || c.is_ascii_digit() => self.number(),
            Some(_) => {
                let start = self.i;
                let Some(name) = self.identifier() else {
                    return Err(format!("unexpected `{}` at column {}", self.rest(), start + 1));
                };
                match name.as_str() {
                    "true" => return Ok(Value::Bool(true)),
                    "false" => return Ok(Value::Bool(false)),
                    "None" => return Ok(Value::Null),
                    "inf" | "NaN" => return Err(format!("`{name}` is not a finite number")),
                    _ => {}
                }
                if self.peek() != Some(b'(') {
                    return Ok(Value::String(name)); // unit variant
                }
                self.i += 1;
                let inner = self.parenthesised()?;
                if name == "Some" {
                    return Ok(inner);
                }
                let mut map = Map::new();
                map.insert(name, inner);
                Ok(Value::Object(map))
            }
        }
    }

    /// After `(`: a struct `(k: v, …)` → object, one value `(v)` → v, a tuple → array.
    fn parenthesised(&mut self) -> Result<Value, String> {
        let save = self.i;
        if let Some(key) = self.identifier() {
            if self.peek() == Some(b':') {
                self.i += 1;
                let mut map = Map::new();
                map.insert(key, self.value()?);
                loop {
                    match self.peek() {
                        Some(b',') => {
                            self.i += 1;
                            if self.peek() == Some(b')') {
                                self.i += 1;
                                return Ok(Value::Object(map));
                            }
                            let Some(k) = self.identifier() else {
                                return Err(format!("expected a key at column {}", self.i + 1));
                            };
                            self.expect(b':')?;
                            map.insert(k, self.value()?);
                        }
                        Some(b')') => {
                            self.i += 1;
                            return Ok(Value::Object(map));
                        }
                        _ => return Err(format!("expected `,` or `)` at column {}", self.i + 1)),
                    }
                }
            }
        }
        self.i = save;
        let mut items = self.sequence(b')')?;
        Ok(if items.len() == 1 { items.pop().expect("one item") } else { Value::Array(items) })
    }

    fn sequence(&mut self, close: u8) -> Result<Vec<Value>, String> {
        let mut items = Vec::new();
        loop {
            if self.peek() == Some(close) {
                self.i += 1;
                return Ok(items);
            }
            items.push(self.value()?);
            match self.peek() {
                Some(b',') => self.i += 1,
                Some(c) if c == close => {}
                _ => return Err(format!("expected `,` or `{}` at column {}", close as char, self.i + 1)),
            }
        }
    }

    fn string(&mut self) -> Result<String, String> {
        self.expect(b'"')?;
        let mut out = String::new();
        let text = std::str::from_utf8(&self.s[self.i..]).map_err(|e| e.to_string())?;
        let mut chars = text.char_indices();
        while let Some((k, c)) = chars.next() {
            match c {
                '"' => {
                    self.i += k + 1;
                    return Ok(out);
                }
                '\\' => match chars.next() {
                    Some((_, 'n')) => out.push('\n'),
                    Some((_, 't')) => out.push('\t'),
                    Some((_, e)) => out.push(e),
                    None => break,
                },
                c => out.push(c),
            }
        }
        Err("a string is not closed with `\"`".into())
    }

    fn number(&mut self) -> Result<Value, String> {
        let start = self.i;
        while self.i < self.s.len() && matches!(self.s[self.i], b'0'..=b'9' | b'-' | b'+' | b'.' | b'e' | b'E' | b'_') {
            self.i += 1;
        }
        let text: String = String::from_utf8_lossy(&self.s[start..self.i]).replace('_', "");
        if let Ok(n) = text.parse::<i64>() {
            return Ok(Value::Number(n.into()));
        }
        let x: f64 = text.parse().map_err(|_| format!("`{text}` at column {} is not a number", start + 1))?;
        Number::from_f64(x).map(Value::Number).ok_or_else(|| format!("`{text}` is not a finite number"))
    }
}

#[cfg(test)]
mod tests {
    use super::parse;
    use serde_json::json;

    #[test]
    fn enum_variants_keep_their_names() {
        assert_eq!(parse("Periodic").unwrap(), json!("Periodic"));
        assert_eq!(parse("Uniform((1.0, -2))").unwrap(), json!({"Uniform": [1.0, -2]}));
        assert_eq!(
            parse("Disk(center: (1.0, 2.5e-1), radius: 0.1,)").unwrap(),
            json!({"Disk": {"center": [1.0, 0.25], "radius": 0.1}})
        );
        assert_eq!(
            parse("Velocity(velocity: (1.0, 0.0), profile: Parabolic)").unwrap(),
            json!({"Velocity": {"velocity": [1.0, 0.0], "profile": "Parabolic"}})
        );
        assert_eq!(
            parse(r#"Some((model: "pcg", params: (tolerance: 1e-8)))"#).unwrap(),
            json!({"model": "pcg", "params": {"tolerance": 1e-8}})
        );
        assert_eq!(parse("None").unwrap(), json!(null));
        assert_eq!(parse("[(a: 1), (a: 2)]").unwrap(), json!([{"a": 1}, {"a": 2}]));
        assert_eq!(parse(r#""a \"b\"""#).unwrap(), json!("a \"b\""));
        assert_eq!(parse("(192, 576)").unwrap(), json!([192, 576]));
        assert_eq!(parse("true").unwrap(), json!(true));
    }

    #[test]
    fn malformed_values_say_where() {
        assert!(parse("(1, 2").unwrap_err().contains("expected"));
        assert!(parse("Disk(center: (1, 2) radius: 1)").unwrap_err().contains("column 21"));
        assert!(parse("1 2").unwrap_err().contains("column 3"));
    }
}
