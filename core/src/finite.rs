//! One walk over every real number of a serializable value (a case), that finds the first
//! NaN or infinity and its path as `--set` spells it (`fields.water.density`,
//! `fields.disks.region.Bodies.b1.shape.Disk.center.0`): entries of lists with a `name`
//! are named by it, enum variants by their name.

use serde::ser::{self, Serialize};
use std::fmt;

/// The path and value of the first real of `value` that is not finite, if any.
pub fn first_non_finite<T: Serialize + ?Sized>(value: &T) -> Option<(String, f64)> {
    let mut walk = Walk { path: Vec::new() };
    match value.serialize(&mut walk) {
        Err(Stop::Found(path, x)) => Some((path, x)),
        _ => None,
    }
}

enum Segment {
    Key(String),
    Index(usize, Option<String>),
}

struct Walk {
    path: Vec<Segment>,
}

impl Walk {
    fn path(&self) -> String {
        let parts: Vec<String> = self
            .path
            .iter()
            .map(|s| match s {
                Segment::Key(k) => k.clone(),
                Segment::Index(_, Some(name)) => name.clone(),
                Segment::Index(i, None) => i.to_string(),
            })
            .collect();
        parts.join(".")
    }
    fn real(&mut self, x: f64) -> Result<(), Stop> {
        if x.is_finite() {
            Ok(())
        } else {
            Err(Stop::Found(self.path(), x))
        }
    }
}

#[derive(Debug)]
enum Stop {
    Found(String, f64),
    Other(String),
}

impl fmt::Display for Stop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Stop::Found(p, x) => write!(f, "{p}: {x}"),
            Stop::Other(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Stop {}

impl ser::Error for Stop {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Stop::Other(msg.to_string())
    }
}

/// A list, tuple, map, struct or variant being walked: the index of its next element and
/// whether it pushed a segment (a variant's name) to pop at its end.
struct Compound<'a> {
    walk: &'a mut Walk,
    index: usize,
    pushed: bool,
}

impl Compound<'_> {
    fn element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.walk.path.push(Segment::Index(self.index, None));
        self.index += 1;
        value.serialize(&mut *self.walk)?;
        self.walk.path.pop();
        Ok(())
    }
    fn field<T: Serialize + ?Sized>(&mut self, key: &str, value: &T) -> Result<(), Stop> {
        self.walk.path.push(Segment::Key(key.to_string()));
        value.serialize(&mut *self.walk)?;
        self.walk.path.pop();
        Ok(())
    }
    fn end(self) -> Result<(), Stop> {
        if self.pushed {
            self.walk.path.pop();
        }
        Ok(())
    }
}

impl<'a> ser::Serializer for &'a mut Walk {
    type Ok = ();
    type Error = Stop;
    type SerializeSeq = Compound<'a>;
    type SerializeTuple = Compound<'a>;
    type SerializeTupleStruct = Compound<'a>;
    type SerializeTupleVariant = Compound<'a>;
    type SerializeMap = Compound<'a>;
    type SerializeStruct = Compound<'a>;
    type SerializeStructVariant = Compound<'a>;

    fn serialize_bool(self, _: bool) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i8(self, _: i8) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i16(self, _: i16) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i32(self, _: i32) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i64(self, _: i64) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u8(self, _: u8) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u16(self, _: u16) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u32(self, _: u32) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u64(self, _: u64) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_f32(self, x: f32) -> Result<(), Stop> {
        self.real(f64::from(x))
    }
    fn serialize_f64(self, x: f64) -> Result<(), Stop> {
        self.real(x)
    }
    fn serialize_char(self, _: char) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_str(self, v: &str) -> Result<(), Stop> {
        // `name: "water"` in an entry of a list names the entry
        let n = self.path.len();
        if n >= 2 && matches!(&self.path[n - 1], Segment::Key(k) if k == "name") {
            if let Segment::Index(_, name @ None) = &mut self.path[n - 2] {
                *name = Some(v.to_string());
            }
        }
        Ok(())
    }
    fn serialize_bytes(self, _: &[u8]) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_none(self) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<(), Stop> {
        value.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(self, _: &'static str, value: &T) -> Result<(), Stop> {
        value.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<(), Stop> {
        self.path.push(Segment::Key(variant.to_string()));
        value.serialize(&mut *self)?;
        self.path.pop();
        Ok(())
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Compound<'a>, Stop> {
        Ok(Compound { walk: self, index: 0, pushed: false })
    }
    fn serialize_tuple(self, _: usize) -> Result<Compound<'a>, Stop> {
        Ok(Compound { walk: self, index: 0, pushed: false })
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Compound<'a>, Stop> {
        Ok(Compound { walk: self, index: 0, pushed: false })
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        _: usize,
    ) -> Result<Compound<'a>, Stop> {
        self.path.push(Segment::Key(variant.to_string()));
        Ok(Compound { walk: self, index: 0, pushed: true })
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Compound<'a>, Stop> {
        Ok(Compound { walk: self, index: 0, pushed: false })
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Compound<'a>, Stop> {
        Ok(Compound { walk: self, index: 0, pushed: false })
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        _: usize,
    ) -> Result<Compound<'a>, Stop> {
        self.path.push(Segment::Key(variant.to_string()));
        Ok(Compound { walk: self, index: 0, pushed: true })
    }
}

impl ser::SerializeSeq for Compound<'_> {
    type Ok = ();
    type Error = Stop;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.element(value)
    }
    fn end(self) -> Result<(), Stop> {
        Compound::end(self)
    }
}

impl ser::SerializeTuple for Compound<'_> {
    type Ok = ();
    type Error = Stop;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.element(value)
    }
    fn end(self) -> Result<(), Stop> {
        Compound::end(self)
    }
}

impl ser::SerializeTupleStruct for Compound<'_> {
    type Ok = ();
    type Error = Stop;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.element(value)
    }
    fn end(self) -> Result<(), Stop> {
        Compound::end(self)
    }
}

impl ser::SerializeTupleVariant for Compound<'_> {
    type Ok = ();
    type Error = Stop;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.element(value)
    }
    fn end(self) -> Result<(), Stop> {
        Compound::end(self)
    }
}

impl ser::SerializeMap for Compound<'_> {
    type Ok = ();
    type Error = Stop;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), Stop> {
        let key = match serde_json::to_value(key) {
            Ok(serde_json::Value::String(s)) => s,
            Ok(other) => other.to_string(),
            Err(_) => self.index.to_string(),
        };
        self.index += 1;
        self.walk.path.push(Segment::Key(key));
        Ok(())
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        value.serialize(&mut *self.walk)?;
        self.walk.path.pop();
        Ok(())
    }
    fn end(self) -> Result<(), Stop> {
        Compound::end(self)
    }
}

impl ser::SerializeStruct for Compound<'_> {
    type Ok = ();
    type Error = Stop;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, key: &'static str, value: &T) -> Result<(), Stop> {
        self.field(key, value)
    }
    fn end(self) -> Result<(), Stop> {
        Compound::end(self)
    }
}

impl ser::SerializeStructVariant for Compound<'_> {
    type Ok = ();
    type Error = Stop;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, key: &'static str, value: &T) -> Result<(), Stop> {
        self.field(key, value)
    }
    fn end(self) -> Result<(), Stop> {
        Compound::end(self)
    }
}

/// Deserializes plugin parameters as serde_json's `Value` does, except that a NaN or an
/// infinity is refused (serde_json's `Value` would turn it into `null`, and the plugin
/// would then say `invalid type: null`).
pub fn finite_json<'de, D: serde::Deserializer<'de>>(d: D) -> Result<serde_json::Value, D::Error> {
    d.deserialize_any(FiniteJson).map(|FiniteValue(v)| v)
}

struct FiniteValue(serde_json::Value);

impl<'de> serde::Deserialize<'de> for FiniteValue {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(FiniteJson)
    }
}

struct FiniteJson;

impl<'de> serde::de::Visitor<'de> for FiniteJson {
    type Value = FiniteValue;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<FiniteValue, E> {
        Ok(FiniteValue(v.into()))
    }
    fn visit_i64<E>(self, v: i64) -> Result<FiniteValue, E> {
        Ok(FiniteValue(v.into()))
    }
    fn visit_u64<E>(self, v: u64) -> Result<FiniteValue, E> {
        Ok(FiniteValue(v.into()))
    }
    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<FiniteValue, E> {
        match serde_json::Number::from_f64(v) {
            Some(n) => Ok(FiniteValue(serde_json::Value::Number(n))),
            None => Err(E::custom(format!(
                "{v} is not a finite number: every number of a case is finite; give a finite value"
            ))),
        }
    }
    fn visit_str<E>(self, v: &str) -> Result<FiniteValue, E> {
        Ok(FiniteValue(v.into()))
    }
    fn visit_string<E>(self, v: String) -> Result<FiniteValue, E> {
        Ok(FiniteValue(v.into()))
    }
    fn visit_none<E>(self) -> Result<FiniteValue, E> {
        Ok(FiniteValue(serde_json::Value::Null))
    }
    fn visit_unit<E>(self) -> Result<FiniteValue, E> {
        Ok(FiniteValue(serde_json::Value::Null))
    }
    fn visit_some<D: serde::Deserializer<'de>>(self, d: D) -> Result<FiniteValue, D::Error> {
        d.deserialize_any(FiniteJson)
    }
    fn visit_newtype_struct<D: serde::Deserializer<'de>>(self, d: D) -> Result<FiniteValue, D::Error> {
        d.deserialize_any(FiniteJson)
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<FiniteValue, A::Error> {
        let mut items = Vec::new();
        while let Some(FiniteValue(v)) = seq.next_element()? {
            items.push(v);
        }
        Ok(FiniteValue(serde_json::Value::Array(items)))
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<FiniteValue, A::Error> {
        let mut out = serde_json::Map::new();
        while let Some((k, FiniteValue(v))) = map.next_entry::<String, FiniteValue>()? {
            out.insert(k, v);
        }
        Ok(FiniteValue(serde_json::Value::Object(out)))
    }
}

#[cfg(test)]
mod tests {
    use super::first_non_finite;
    use serde::Serialize;

    #[derive(Serialize)]
    struct Field {
        name: String,
        density: f64,
        shape: Shape,
    }

    #[derive(Serialize)]
    enum Shape {
        Disk { center: [f64; 2] },
    }

    #[test]
    fn the_path_names_entries_and_variants() {
        let ok = vec![Field { name: "water".into(), density: 1.0, shape: Shape::Disk { center: [0.0, 1.0] } }];
        assert_eq!(first_non_finite(&ok), None);
        let bad = vec![
            Field { name: "water".into(), density: 1.0, shape: Shape::Disk { center: [0.0, 1.0] } },
            Field { name: "sand".into(), density: 1.0, shape: Shape::Disk { center: [0.0, f64::INFINITY] } },
        ];
        assert_eq!(
            first_non_finite(&bad),
            Some(("1.shape.Disk.center.1".replace("1.shape", "sand.shape"), f64::INFINITY))
        );
        let nan = Field { name: "w".into(), density: f64::NAN, shape: Shape::Disk { center: [0.0, 1.0] } };
        assert_eq!(first_non_finite(&nan).map(|(p, _)| p), Some("density".to_string()));
    }
}
