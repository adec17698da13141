//! The columns of any message, from its fields (serde serializes them in `.msg` order):
//! nested messages flatten to `outer_inner`, a top-level `header` to `stamp_s` and
//! `frame_id`, a `builtin_interfaces/Time` to one exact `<name>_s` column, a sequence to
//! `<name>_0`, `<name>_1`, … and a bool to 0 / 1. A field added to a `.msg` (and its struct)
//! is a column without any change here.

use serde::ser::{self, Serialize};

/// One message's cells: (column, CSV cell text without the leading comma).
pub type Cells = Vec<(String, String)>;

/// The flattened cells of `msg`, in field order.
pub fn cells<M: Serialize>(msg: &M) -> Cells {
    let mut f = Flat { path: Vec::new(), cells: Vec::new(), time: None };
    // Only our message structs come here: their Serialize cannot fail on this serializer.
    let _ = msg.serialize(&mut f);
    f.cells
}

struct Flat {
    path: Vec<String>,
    cells: Cells,
    /// Inside a `Time`: (sec, nanosec) so far.
    time: Option<(i64, u64)>,
}

#[derive(Debug)]
pub struct FlatError(String);

impl std::fmt::Display for FlatError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for FlatError {}
impl ser::Error for FlatError {
    fn custom<T: std::fmt::Display>(msg: T) -> Self {
        FlatError(msg.to_string())
    }
}

impl Flat {
    fn column(&self) -> String {
        // A top-level header's fields keep their own names (`stamp_s`, `frame_id`).
        let skip = usize::from(self.path.len() > 1 && self.path[0] == "header");
        self.path[skip..].join("_")
    }

    fn push(&mut self, cell: String) {
        let col = self.column();
        self.cells.push((col, cell));
    }

    fn int(&mut self, v: i128) {
        if let Some((sec, nsec)) = self.time.as_mut() {
            match self.path.last().map(String::as_str) {
                Some("sec") => *sec = v as i64,
                _ => *nsec = v as u64,
            }
            return;
        }
        self.push(v.to_string());
    }
}

fn csv_text(v: &str) -> String {
    if v.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", v.replace('"', "\"\""))
    } else {
        v.to_string()
    }
}

impl<'a> ser::Serializer for &'a mut Flat {
    type Ok = ();
    type Error = FlatError;
    type SerializeSeq = Seq<'a>;
    type SerializeTuple = Seq<'a>;
    type SerializeTupleStruct = Seq<'a>;
    type SerializeTupleVariant = Seq<'a>;
    type SerializeMap = ser::Impossible<(), FlatError>;
    type SerializeStruct = Struct<'a>;
    type SerializeStructVariant = ser::Impossible<(), FlatError>;

    fn serialize_bool(self, v: bool) -> Result<(), FlatError> {
        self.push(u8::from(v).to_string());
        Ok(())
    }
    fn serialize_i8(self, v: i8) -> Result<(), FlatError> {
        self.int(v.into());
        Ok(())
    }
    fn serialize_i16(self, v: i16) -> Result<(), FlatError> {
        self.int(v.into());
        Ok(())
    }
    fn serialize_i32(self, v: i32) -> Result<(), FlatError> {
        self.int(v.into());
        Ok(())
    }
    fn serialize_i64(self, v: i64) -> Result<(), FlatError> {
        self.int(v.into());
        Ok(())
    }
    fn serialize_u8(self, v: u8) -> Result<(), FlatError> {
        self.int(v.into());
        Ok(())
    }
    fn serialize_u16(self, v: u16) -> Result<(), FlatError> {
        self.int(v.into());
        Ok(())
    }
    fn serialize_u32(self, v: u32) -> Result<(), FlatError> {
        self.int(v.into());
        Ok(())
    }
    fn serialize_u64(self, v: u64) -> Result<(), FlatError> {
        self.int(v.into());
        Ok(())
    }
    fn serialize_f32(self, v: f32) -> Result<(), FlatError> {
        self.push(v.to_string());
        Ok(())
    }
    fn serialize_f64(self, v: f64) -> Result<(), FlatError> {
        self.push(v.to_string());
        Ok(())
    }
    fn serialize_char(self, v: char) -> Result<(), FlatError> {
        self.push(csv_text(&v.to_string()));
        Ok(())
    }
    fn serialize_str(self, v: &str) -> Result<(), FlatError> {
        self.push(csv_text(v));
        Ok(())
    }
    fn serialize_bytes(self, v: &[u8]) -> Result<(), FlatError> {
        for (i, b) in v.iter().enumerate() {
            self.path.push(i.to_string());
            self.push(b.to_string());
            self.path.pop();
        }
        Ok(())
    }
    fn serialize_none(self) -> Result<(), FlatError> {
        self.push(String::new());
        Ok(())
    }
    fn serialize_some<T: ?Sized + Serialize>(self, v: &T) -> Result<(), FlatError> {
        v.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), FlatError> {
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), FlatError> {
        Ok(())
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, v: &'static str) -> Result<(), FlatError> {
        self.push(v.to_string());
        Ok(())
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(self, _: &'static str, v: &T) -> Result<(), FlatError> {
        v.serialize(self)
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(self, _: &'static str, _: u32, _: &'static str, v: &T) -> Result<(), FlatError> {
        v.serialize(self)
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Seq<'a>, FlatError> {
        Ok(Seq { f: self, i: 0 })
    }
    fn serialize_tuple(self, _: usize) -> Result<Seq<'a>, FlatError> {
        Ok(Seq { f: self, i: 0 })
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Seq<'a>, FlatError> {
        Ok(Seq { f: self, i: 0 })
    }
    fn serialize_tuple_variant(self, _: &'static str, _: u32, _: &'static str, _: usize) -> Result<Seq<'a>, FlatError> {
        Ok(Seq { f: self, i: 0 })
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, FlatError> {
        Err(ser::Error::custom("maps are not message fields"))
    }
    fn serialize_struct(self, name: &'static str, _: usize) -> Result<Struct<'a>, FlatError> {
        // builtin_interfaces/Time: one exact `sec.nanosec` column.
        let is_time = name == "Time" && self.time.is_none();
        if is_time {
            self.time = Some((0, 0));
        }
        Ok(Struct { f: self, is_time })
    }
    fn serialize_struct_variant(self, _: &'static str, _: u32, _: &'static str, _: usize) -> Result<Self::SerializeStructVariant, FlatError> {
        Err(ser::Error::custom("enums are not message fields"))
    }
}

pub struct Seq<'a> {
    f: &'a mut Flat,
    i: usize,
}

impl Seq<'_> {
    fn element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), FlatError> {
        self.f.path.push(self.i.to_string());
        self.i += 1;
        let r = v.serialize(&mut *self.f);
        self.f.path.pop();
        r
    }
}

impl ser::SerializeSeq for Seq<'_> {
    type Ok = ();
    type Error = FlatError;
    fn serialize_element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), FlatError> {
        self.element(v)
    }
    fn end(self) -> Result<(), FlatError> {
        Ok(())
    }
}
impl ser::SerializeTuple for Seq<'_> {
    type Ok = ();
    type Error = FlatError;
    fn serialize_element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), FlatError> {
        self.element(v)
    }
    fn end(self) -> Result<(), FlatError> {
        Ok(())
    }
}
impl ser::SerializeTupleStruct for Seq<'_> {
    type Ok = ();
    type Error = FlatError;
    fn serialize_field<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), FlatError> {
        self.element(v)
    }
    fn end(self) -> Result<(), FlatError> {
        Ok(())
    }
}
impl ser::SerializeTupleVariant for Seq<'_> {
    type Ok = ();
    type Error = FlatError;
    fn serialize_field<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), FlatError> {
        self.element(v)
    }
    fn end(self) -> Result<(), FlatError> {
        Ok(())
    }
}

pub struct Struct<'a> {
    f: &'a mut Flat,
    is_time: bool,
}

impl ser::SerializeStruct for Struct<'_> {
    type Ok = ();
    type Error = FlatError;
    fn serialize_field<T: ?Sized + Serialize>(&mut self, key: &'static str, v: &T) -> Result<(), FlatError> {
        self.f.path.push(key.to_string());
        let r = v.serialize(&mut *self.f);
        self.f.path.pop();
        r
    }
    fn end(self) -> Result<(), FlatError> {
        if self.is_time {
            let (sec, nsec) = self.f.time.take().unwrap_or((0, 0));
            let ns = sec * 1_000_000_000 + nsec as i64;
            let sign = if ns < 0 { "-" } else { "" };
            let cell = format!("{sign}{}.{:09}", ns.unsigned_abs() / 1_000_000_000, ns.unsigned_abs() % 1_000_000_000);
            self.f.path.push("s".into());
            self.f.push(cell);
            self.f.path.pop();
        }
        Ok(())
    }
}

/// The columns of all `rows`, each row's in its order: a column one row lacks (a shorter
/// sequence) stays where the rows that have it put it.
pub fn columns(rows: &[Cells]) -> Vec<String> {
    let mut cols: Vec<String> = Vec::new();
    let mut prev: Option<&Cells> = None;
    for row in rows {
        // Most rows have the previous row's columns: nothing to merge.
        if prev.is_some_and(|p| p.len() == row.len() && p.iter().zip(row).all(|(a, b)| a.0 == b.0)) {
            continue;
        }
        prev = Some(row);
        let mut at = 0;
        for (c, _) in row {
            match cols.iter().position(|x| x == c) {
                Some(i) => at = i + 1,
                None => {
                    cols.insert(at, c.clone());
                    at += 1;
                }
            }
        }
    }
    cols
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_msgs::{NaicParams, RosMessage};

    /// Every field of `NaicParams.msg` is a column, in `.msg` order (read from the `.msg`
    /// text, not from the struct): a field the CSV drops fails here.
    #[test]
    fn naic_params_has_a_column_for_every_field_of_its_msg_file() {
        let m = NaicParams {
            reference_position: vec![0.1, 0.2, 0.3],
            gamma_bound: f64::INFINITY,
            fault: "a, \"quoted\" fault".into(),
            k_e_hat: 1234.5,
            model_gain: 0.75,
            gravity_scale: 1.25,
            wrench_bias: vec![0.5, 0.0, -0.5, 0.01, 0.02, 0.03],
            gamma_clipped: true,
            ..Default::default()
        };
        let cells = cells(&m);
        let cols: Vec<&str> = cells.iter().map(|(c, _)| c.as_str()).collect();
        let mut want = vec!["stamp_s".to_string(), "frame_id".to_string()];
        for line in NaicParams::type_info().msg_text.lines() {
            let line = line.split('#').next().unwrap_or("").trim();
            let mut w = line.split_whitespace();
            let (Some(ty), Some(name)) = (w.next(), w.next()) else { continue };
            if name.contains('=') || ty == "std_msgs/Header" {
                continue; // constants; the header is stamp_s, frame_id
            }
            if ty.ends_with("[]") {
                let n = if name == "wrench_bias" { 6 } else { 3 };
                want.extend((0..n).map(|i| format!("{name}_{i}")));
            } else {
                want.push(name.to_string());
            }
        }
        assert!(want.len() > 25, "{want:?}");
        assert_eq!(cols, want);
        let cell = |c: &str| cells.iter().find(|(n, _)| n == c).map(|(_, v)| v.as_str()).unwrap();
        assert_eq!(
            (cell("k_e_hat"), cell("model_gain"), cell("gravity_scale"), cell("gamma_bound")),
            ("1234.5", "0.75", "1.25", "inf")
        );
        assert_eq!((cell("gamma_clipped"), cell("reference_position_2"), cell("stamp_s")), ("1", "0.3", "0.000000000"));
        assert_eq!(cell("fault"), "\"a, \"\"quoted\"\" fault\"");
    }

    #[test]
    fn a_shorter_sequence_keeps_the_column_order() {
        let a = NaicParams { reference_position: vec![1.0], ..Default::default() };
        let b = NaicParams { reference_position: vec![1.0, 2.0, 3.0], ..Default::default() };
        let cols = columns(&[cells(&a), cells(&b)]);
        let i = |c: &str| cols.iter().position(|x| x == c).unwrap();
        assert!(i("reference_position_0") < i("reference_position_1") && i("reference_position_2") < i("reference_stale"));
        assert_eq!(cols.len(), cells(&b).len());
    }
}
