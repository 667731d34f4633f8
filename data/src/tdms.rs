//! NI TDMS files (LabVIEW, DIAdem, NI DAQ software, npTDMS), read by a parser of our
//! own.
//!
//! Why our own: the format's documented core (NI's "TDMS File Format Internal
//! Structure") is small, and we need what a general reader does not promise — every
//! malformed byte an error that names where, never a panic, nothing dropped, bounded
//! work on hostile input (fuzz target `tdms`).
//!
//! ```text
//! segment* — each: lead-in (28 B: "TDSm", ToC mask, version 4712/4713, offset of the
//!   next segment, offset of the raw data; tag and ToC little-endian, the rest in the
//!   segment's byte order), metadata, raw data
//! metadata: objects (path `/'group'/'channel'`, raw-data index, properties);
//!   the index: none (0xFFFFFFFF), "as in the previous segment" (0), or type,
//!   dimension 1, value count; a segment without kTocNewObjList carries the previous
//!   object list forward (objects it names are updated or appended); a segment
//!   without metadata reuses the previous one whole
//! raw data: chunks of every data object's values, contiguous per object or
//!   interleaved value by value
//! → one FileChannel per channel object that held data: name (the channel's, or
//!   `group/channel` when two groups share it), `unit_string`, the rate from
//!   `wf_increment` (channel, else group), samples as f32
//! ```
//!
//! Read: integer and float channels (i8–i64, u8–u64, f32, f64, with or without a unit
//! type), little- and big-endian segments, incremental metadata, interleaved data, an
//! unfinished last segment (next-segment offset all ones: its data runs to the end of
//! the file). Refused with a named error: DAQmx raw data, strings, timestamps,
//! complex or extended-precision values in raw data, raw counts that carry NI's
//! scaling properties (`NI_Number_Of_Scales`: the values would be counts, not
//! physical units), a chunk cut short.

use std::collections::HashMap;

use crate::channels::FileChannel;

/// What can go wrong reading a TDMS file.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum TdmsError {
    /// The file ends inside a structure.
    #[error("truncated at byte {at}: {what} needs {need} bytes, {left} left")]
    Truncated {
        /// Byte offset.
        at: usize,
        /// What was being read.
        what: &'static str,
        /// Bytes needed.
        need: u64,
        /// Bytes left.
        left: usize,
    },
    /// A structure is malformed.
    #[error("malformed TDMS at byte {at}: {reason}")]
    Format {
        /// Byte offset.
        at: usize,
        /// What is wrong.
        reason: String,
    },
    /// A valid TDMS feature this reader does not read.
    #[error("unsupported TDMS content in `{object}`: {what}")]
    Unsupported {
        /// The object's path.
        object: String,
        /// What it holds.
        what: String,
    },
}

const LEAD_IN: usize = 28;
const TOC_META: u32 = 1 << 1;
const TOC_RAW: u32 = 1 << 3;
const TOC_NEW_LIST: u32 = 1 << 2;
const TOC_INTERLEAVED: u32 = 1 << 5;
const TOC_BIG_ENDIAN: u32 = 1 << 6;
const TOC_DAQMX: u32 = 1 << 7;
const NO_DATA: u32 = 0xFFFF_FFFF;
const SAME_AS_BEFORE: u32 = 0;

/// A raw-data value type this reader turns into samples.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Numeric {
    I8,
    I16,
    I32,
    I64,
    U8,
    U16,
    U32,
    U64,
    F32,
    F64,
}

impl Numeric {
    fn from_code(code: u32) -> Option<Self> {
        Some(match code {
            1 => Self::I8,
            2 => Self::I16,
            3 => Self::I32,
            4 => Self::I64,
            5 => Self::U8,
            6 => Self::U16,
            7 => Self::U32,
            8 => Self::U64,
            9 | 0x19 => Self::F32,
            10 | 0x1A => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::I64 | Self::U64 | Self::F64 => 8,
        }
    }
}

/// The name of a type code, for errors.
fn type_name(code: u32) -> String {
    match code {
        0x0B | 0x1B => "extended-precision floats".into(),
        0x20 => "strings".into(),
        0x21 => "booleans".into(),
        0x44 => "timestamps".into(),
        0x08_000C | 0x10_000D => "complex values".into(),
        0xFFFF_FFFF => "DAQmx raw data".into(),
        c => format!("values of type code 0x{c:X}"),
    }
}

/// A cursor over the file with the current segment's byte order.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
    big: bool,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: u64, what: &'static str) -> Result<&'a [u8], TdmsError> {
        let left = self.bytes.len() - self.at;
        if n > left as u64 {
            return Err(TdmsError::Truncated {
                at: self.at,
                what,
                need: n,
                left,
            });
        }
        let s = &self.bytes[self.at..self.at + n as usize];
        self.at += n as usize;
        Ok(s)
    }

    fn array<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], TdmsError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N as u64, what)?);
        if self.big {
            a.reverse();
        }
        Ok(a)
    }

    fn u32(&mut self, what: &'static str) -> Result<u32, TdmsError> {
        self.array::<4>(what).map(u32::from_le_bytes)
    }

    fn u64(&mut self, what: &'static str) -> Result<u64, TdmsError> {
        self.array::<8>(what).map(u64::from_le_bytes)
    }

    fn string(&mut self, what: &'static str) -> Result<String, TdmsError> {
        let at = self.at;
        let n = self.u32(what)?;
        let raw = self.take(u64::from(n), what)?;
        String::from_utf8(raw.to_vec()).map_err(|_| TdmsError::Format {
            at,
            reason: format!("{what} is not UTF-8"),
        })
    }

    /// One value of a numeric type, as f64.
    fn value(&mut self, t: Numeric) -> Result<f64, TdmsError> {
        const W: &str = "a value";
        Ok(match t {
            Numeric::I8 => f64::from(i8::from_le_bytes(self.array::<1>(W)?)),
            Numeric::I16 => f64::from(i16::from_le_bytes(self.array::<2>(W)?)),
            Numeric::I32 => f64::from(i32::from_le_bytes(self.array::<4>(W)?)),
            Numeric::I64 => i64::from_le_bytes(self.array::<8>(W)?) as f64,
            Numeric::U8 => f64::from(self.array::<1>(W)?[0]),
            Numeric::U16 => f64::from(u16::from_le_bytes(self.array::<2>(W)?)),
            Numeric::U32 => f64::from(u32::from_le_bytes(self.array::<4>(W)?)),
            Numeric::U64 => u64::from_le_bytes(self.array::<8>(W)?) as f64,
            Numeric::F32 => f64::from(f32::from_le_bytes(self.array::<4>(W)?)),
            Numeric::F64 => f64::from_le_bytes(self.array::<8>(W)?),
        })
    }
}

/// A property value this reader keeps (numbers and text); others are skipped.
#[derive(Debug, Clone, PartialEq)]
enum Property {
    Number(f64),
    Text(String),
    Other,
}

/// Read one property value of type `code`.
fn property(c: &mut Cursor<'_>, code: u32) -> Result<Property, TdmsError> {
    if let Some(t) = Numeric::from_code(code) {
        return c.value(t).map(Property::Number);
    }
    let skip = match code {
        0x20 => return c.string("a string property").map(Property::Text),
        0x21 => 1,
        0x08_000C => 8,
        0x0B | 0x1B | 0x44 | 0x10_000D => 16,
        other => {
            return Err(TdmsError::Format {
                at: c.at,
                reason: format!("property of unknown type code 0x{other:X}"),
            })
        }
    };
    c.take(skip, "a property").map(|_| Property::Other)
}

/// A raw-data index: the value type and count per chunk.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Index {
    kind: Numeric,
    count: u64,
}

/// Everything read of one object, across segments.
#[derive(Debug, Default)]
struct Object {
    path: String,
    properties: Vec<(String, Property)>,
    /// The index of the last segment that gave one (for "as before").
    last: Option<Index>,
    data: Vec<f32>,
    had_data: bool,
}

impl Object {
    fn number(&self, name: &str) -> Option<f64> {
        self.properties.iter().rev().find_map(|(n, v)| match v {
            Property::Number(x) if n == name => Some(*x),
            _ => None,
        })
    }

    fn text(&self, name: &str) -> Option<&str> {
        self.properties.iter().rev().find_map(|(n, v)| match v {
            Property::Text(s) if n == name => Some(s.as_str()),
            _ => None,
        })
    }

    fn has(&self, name: &str) -> bool {
        self.properties.iter().any(|(n, _)| n == name)
    }
}

/// The objects of the file and the current segment's object list: (object, this
/// segment's index or none).
#[derive(Debug, Default)]
struct State {
    objects: Vec<Object>,
    /// Object index by path (a file may hold many objects: no linear searches).
    by_path: HashMap<String, usize>,
    list: Vec<(usize, Option<Index>)>,
    /// Position in `list` by object index.
    in_list: HashMap<usize, usize>,
    /// The list's objects with data and their chunk size (`None`: to be computed
    /// from `list` again, after new metadata).
    data_objects: Option<(Vec<(usize, Index)>, u64)>,
}

impl State {
    fn object(&mut self, path: &str) -> usize {
        if let Some(&i) = self.by_path.get(path) {
            return i;
        }
        self.objects.push(Object {
            path: path.to_string(),
            ..Object::default()
        });
        self.by_path
            .insert(path.to_string(), self.objects.len() - 1);
        self.objects.len() - 1
    }

    /// Put object `k` with this segment's `index` in the list (updated in place when
    /// it is there already).
    fn list_object(&mut self, k: usize, index: Option<Index>) {
        match self.in_list.get(&k) {
            Some(&at) => self.list[at].1 = index,
            None => {
                self.in_list.insert(k, self.list.len());
                self.list.push((k, index));
            }
        }
    }
}

/// Read a segment's metadata into the state.
fn metadata(c: &mut Cursor<'_>, state: &mut State, new_list: bool) -> Result<(), TdmsError> {
    state.data_objects = None;
    if new_list {
        state.list.clear();
        state.in_list.clear();
    }
    let n = c.u32("the object count")?;
    for _ in 0..n {
        let path = c.string("an object path")?;
        let at = c.at;
        let header = c.u32("a raw-data index")?;
        let k = state.object(&path);
        let index = match header {
            NO_DATA => None,
            SAME_AS_BEFORE => Some(state.objects[k].last.ok_or_else(|| TdmsError::Format {
                at,
                reason: format!("`{path}` reuses an index no earlier segment gave"),
            })?),
            0x6912_0000 | 0x6913_0000 => {
                return Err(TdmsError::Unsupported {
                    object: path,
                    what: "DAQmx raw data (format-changing scalers)".into(),
                })
            }
            _ => Some(raw_index(c, &path)?),
        };
        if index.is_some() {
            state.objects[k].last = index;
        }
        let n_props = c.u32("the property count")?;
        for _ in 0..n_props {
            let name = c.string("a property name")?;
            let code = c.u32("a property type")?;
            let value = property(c, code)?;
            state.objects[k].properties.push((name, value));
        }
        state.list_object(k, index);
    }
    Ok(())
}

/// The type, dimension and count of a raw-data index (its length already read).
fn raw_index(c: &mut Cursor<'_>, path: &str) -> Result<Index, TdmsError> {
    let code = c.u32("a data type")?;
    let at = c.at;
    let dimension = c.u32("an array dimension")?;
    let count = c.u64("a value count")?;
    let kind = Numeric::from_code(code).ok_or_else(|| TdmsError::Unsupported {
        object: path.to_string(),
        what: type_name(code),
    })?;
    if dimension != 1 {
        return Err(TdmsError::Format {
            at,
            reason: format!("`{path}`: array dimension {dimension} (TDMS allows only 1)"),
        });
    }
    Ok(Index { kind, count })
}

/// Read a segment's raw data, `[c.at, end)`, into the objects of the current list.
fn raw_data(
    c: &mut Cursor<'_>,
    state: &mut State,
    end: usize,
    interleaved: bool,
) -> Result<(), TdmsError> {
    // The data objects and the chunk size change only with the metadata: computed
    // once per object list, not per segment (a file of many segments without
    // metadata stays linear in its size).
    let (data, chunk) = state.data_objects.get_or_insert_with(|| {
        let data: Vec<(usize, Index)> = state
            .list
            .iter()
            .filter_map(|&(k, i)| i.filter(|i| i.count > 0).map(|i| (k, i)))
            .collect();
        let chunk = data
            .iter()
            .map(|(_, i)| i.count.saturating_mul(i.kind.size() as u64))
            .fold(0u64, u64::saturating_add);
        (data, chunk)
    });
    let (data, chunk) = (&*data, *chunk);
    let len = (end - c.at) as u64;
    if chunk == 0 {
        return if len == 0 {
            Ok(())
        } else {
            Err(TdmsError::Format {
                at: c.at,
                reason: format!("{len} bytes of raw data but no object with data"),
            })
        };
    }
    if len % chunk != 0 {
        return Err(TdmsError::Format {
            at: c.at,
            reason: format!("{len} bytes of raw data are not whole chunks of {chunk} bytes"),
        });
    }
    if interleaved && data.iter().any(|(_, i)| i.count != data[0].1.count) {
        return Err(TdmsError::Format {
            at: c.at,
            reason: "interleaved objects with different value counts".into(),
        });
    }
    for _ in 0..len / chunk {
        if interleaved {
            for _ in 0..data[0].1.count {
                for &(k, i) in data {
                    let v = c.value(i.kind)?;
                    state.objects[k].data.push(v as f32);
                }
            }
        } else {
            for &(k, i) in data {
                for _ in 0..i.count {
                    let v = c.value(i.kind)?;
                    state.objects[k].data.push(v as f32);
                }
            }
        }
    }
    if len > 0 {
        for &(k, _) in data {
            state.objects[k].had_data = true;
        }
    }
    Ok(())
}

/// Read one segment starting at `c.at`; returns where the next one starts.
fn segment(c: &mut Cursor<'_>, state: &mut State) -> Result<usize, TdmsError> {
    let start = c.at;
    c.big = false;
    let tag = c.take(4, "a segment tag")?;
    if tag != b"TDSm" {
        return Err(TdmsError::Format {
            at: start,
            reason: format!("segment tag {tag:?}, expected \"TDSm\""),
        });
    }
    let toc = c.u32("the table of contents")?;
    c.big = toc & TOC_BIG_ENDIAN != 0;
    let version = c.u32("the version")?;
    if version != 4712 && version != 4713 {
        return Err(TdmsError::Format {
            at: start + 8,
            reason: format!("version {version}, expected 4712 or 4713"),
        });
    }
    let next = c.u64("the next-segment offset")?;
    let raw = c.u64("the raw-data offset")?;
    let lead_end = start + LEAD_IN;
    let left = (c.bytes.len() - lead_end) as u64;
    // All ones: a segment the writer never finished; its data runs to the end.
    let seg_len = if next == u64::MAX { left } else { next };
    if seg_len > left {
        return Err(TdmsError::Truncated {
            at: lead_end,
            what: "a segment",
            need: seg_len,
            left: left as usize,
        });
    }
    if raw > seg_len {
        return Err(TdmsError::Format {
            at: start + 20,
            reason: format!("raw data at offset {raw}, past the segment's end ({seg_len})"),
        });
    }
    let end = lead_end + seg_len as usize;
    let raw_start = lead_end + raw as usize;
    if toc & TOC_META != 0 {
        let mut meta = Cursor {
            bytes: &c.bytes[..raw_start],
            at: lead_end,
            big: c.big,
        };
        metadata(&mut meta, state, toc & TOC_NEW_LIST != 0)?;
    }
    if toc & TOC_RAW != 0 {
        if toc & TOC_DAQMX != 0 {
            return Err(TdmsError::Unsupported {
                object: "/".into(),
                what: "DAQmx raw data".into(),
            });
        }
        let mut data = Cursor {
            bytes: &c.bytes[..end],
            at: raw_start,
            big: c.big,
        };
        raw_data(&mut data, state, end, toc & TOC_INTERLEAVED != 0)?;
    }
    Ok(end)
}

/// The components of an object path (`/'group'/'channel'`, `''` for a quote).
fn path_parts(path: &str) -> Option<Vec<String>> {
    let mut parts = Vec::new();
    let mut rest = path.strip_prefix('/')?;
    while !rest.is_empty() {
        let mut s = rest.strip_prefix('\'')?;
        let mut part = String::new();
        loop {
            let q = s.find('\'')?;
            part.push_str(&s[..q]);
            s = &s[q + 1..];
            match s.strip_prefix('\'') {
                Some(after) => {
                    part.push('\'');
                    s = after;
                }
                None => break,
            }
        }
        parts.push(part);
        rest = match s.strip_prefix('/') {
            Some(r) => r,
            None if s.is_empty() => s,
            None => return None,
        };
    }
    Some(parts)
}

/// The channels a TDMS file's bytes hold (module docs).
pub fn parse_tdms(bytes: &[u8]) -> Result<Vec<FileChannel>, TdmsError> {
    let mut c = Cursor {
        bytes,
        at: 0,
        big: false,
    };
    let mut state = State::default();
    while c.at < bytes.len() {
        c.at = segment(&mut c, &mut state)?;
    }
    channels(state)
}

/// The channel objects that held data, as file channels.
fn channels(state: State) -> Result<Vec<FileChannel>, TdmsError> {
    let mut found: Vec<(String, String, &Object)> = Vec::new();
    for o in state.objects.iter().filter(|o| o.had_data) {
        let parts = path_parts(&o.path).ok_or_else(|| TdmsError::Format {
            at: 0,
            reason: format!("object path `{}` is not /'group'/'channel'", o.path),
        })?;
        let [group, channel] = parts.as_slice() else {
            return Err(TdmsError::Unsupported {
                object: o.path.clone(),
                what: "raw data on a root or group object".into(),
            });
        };
        // NI's scaling properties describe raw counts unless the data says it is
        // scaled already.
        if o.has("NI_Number_Of_Scales") && o.text("NI_Scaling_Status") != Some("scaled") {
            return Err(TdmsError::Unsupported {
                object: o.path.clone(),
                what: "raw counts with NI scaling properties (export scaled data)".into(),
            });
        }
        found.push((group.clone(), channel.clone(), o));
    }
    let group_increment = |g: &str| {
        let path = format!("/'{}'", g.replace('\'', "''"));
        state
            .objects
            .iter()
            .find(|o| o.path == path)
            .and_then(|o| o.number("wf_increment"))
    };
    let mut out = Vec::with_capacity(found.len());
    for (group, channel, o) in &found {
        let shared = found.iter().filter(|(_, c, _)| c == channel).count() > 1;
        let increment = o.number("wf_increment").or_else(|| group_increment(group));
        let fs_hz = match increment {
            None => None,
            // A denormal step would make an infinite rate, an infinite one a zero rate.
            Some(dt) if dt.is_finite() && dt > 0.0 && (1.0 / dt).is_finite() => Some(1.0 / dt),
            Some(dt) => {
                return Err(TdmsError::Format {
                    at: 0,
                    reason: format!(
                        "`{}`: wf_increment {dt} is not a positive time step",
                        o.path
                    ),
                })
            }
        };
        out.push(FileChannel {
            name: if shared {
                format!("{group}/{channel}")
            } else {
                channel.clone()
            },
            unit: o
                .text("unit_string")
                .map(str::trim)
                .filter(|u| !u.is_empty())
                .map(str::to_string),
            fs_hz,
            samples: o.data.clone(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A property: name, type code, value bytes.
    type Prop = (String, u32, Vec<u8>);
    /// An object: path, index (type code 0: "as before"; count), properties.
    type Obj = (String, Option<(u32, u64)>, Vec<Prop>);

    /// A minimal TDMS writer for the tests: one segment of the given objects.
    struct Seg {
        toc: u32,
        objects: Vec<Obj>,
        raw: Vec<u8>,
    }

    fn put(out: &mut Vec<u8>, big: bool, bytes: &[u8]) {
        if big {
            out.extend(bytes.iter().rev());
        } else {
            out.extend_from_slice(bytes);
        }
    }

    fn put_str(out: &mut Vec<u8>, big: bool, s: &str) {
        put(out, big, &(s.len() as u32).to_le_bytes());
        out.extend_from_slice(s.as_bytes());
    }

    impl Seg {
        fn bytes(&self) -> Vec<u8> {
            let big = self.toc & TOC_BIG_ENDIAN != 0;
            let mut meta = Vec::new();
            if self.toc & TOC_META != 0 {
                put(&mut meta, big, &(self.objects.len() as u32).to_le_bytes());
                for (path, index, props) in &self.objects {
                    put_str(&mut meta, big, path);
                    match index {
                        None => put(&mut meta, big, &NO_DATA.to_le_bytes()),
                        Some((0, _)) => put(&mut meta, big, &0u32.to_le_bytes()),
                        Some((code, count)) => {
                            put(&mut meta, big, &20u32.to_le_bytes());
                            put(&mut meta, big, &code.to_le_bytes());
                            put(&mut meta, big, &1u32.to_le_bytes());
                            put(&mut meta, big, &count.to_le_bytes());
                        }
                    }
                    put(&mut meta, big, &(props.len() as u32).to_le_bytes());
                    for (name, code, value) in props {
                        put_str(&mut meta, big, name);
                        put(&mut meta, big, &code.to_le_bytes());
                        meta.extend_from_slice(value);
                    }
                }
            }
            let mut out = b"TDSm".to_vec();
            out.extend_from_slice(&self.toc.to_le_bytes());
            put(&mut out, big, &4713u32.to_le_bytes());
            put(
                &mut out,
                big,
                &((meta.len() + self.raw.len()) as u64).to_le_bytes(),
            );
            put(&mut out, big, &(meta.len() as u64).to_le_bytes());
            out.extend(meta);
            out.extend_from_slice(&self.raw);
            out
        }
    }

    fn f64_prop(name: &str, v: f64) -> Prop {
        (name.into(), 10, v.to_le_bytes().to_vec())
    }

    fn str_prop(name: &str, v: &str) -> Prop {
        let mut b = (v.len() as u32).to_le_bytes().to_vec();
        b.extend_from_slice(v.as_bytes());
        (name.into(), 0x20, b)
    }

    fn le_f32(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    /// Segment 1: two f32 channels, contiguous, with properties; segment 2: no
    /// metadata (reuses the list); segment 3: incremental metadata adds an i16
    /// channel... of the same count, interleaved.
    fn sample_file() -> Vec<u8> {
        let chan = |name: &str| format!("/'g'/'{name}'");
        let first = Seg {
            toc: TOC_META | TOC_RAW | TOC_NEW_LIST,
            objects: vec![
                ("/".into(), None, vec![str_prop("name", "rig")]),
                (
                    "/'g'".into(),
                    None,
                    vec![f64_prop("wf_increment", 1.0 / 2000.0)],
                ),
                (
                    chan("DE acc"),
                    Some((9, 2)),
                    vec![str_prop("unit_string", "m/s^2")],
                ),
                (
                    chan("FE"),
                    Some((9, 2)),
                    vec![f64_prop("wf_increment", 0.0005)],
                ),
            ],
            raw: le_f32(&[9.80665, 0.0, 1.0, 2.0]),
        };
        let second = Seg {
            toc: TOC_RAW,
            objects: vec![],
            raw: le_f32(&[0.0, 9.80665, 3.0, 4.0, 19.6133, 0.0, 5.0, 6.0]),
        };
        let third = Seg {
            toc: TOC_META | TOC_RAW | TOC_INTERLEAVED,
            objects: vec![(chan("FE"), Some((0, 0)), vec![])],
            raw: le_f32(&[0.0, 7.0, 9.80665, 8.0]),
        };
        [first.bytes(), second.bytes(), third.bytes()].concat()
    }

    #[test]
    fn segments_lists_and_interleaving_are_read() {
        let ch = parse_tdms(&sample_file()).unwrap();
        assert_eq!(ch.len(), 2);
        assert_eq!(ch[0].name, "DE acc");
        assert_eq!(ch[0].unit.as_deref(), Some("m/s^2"));
        assert_eq!(ch[0].fs_hz, Some(2000.0), "the group's increment");
        let g = 9.80665f32;
        assert_eq!(ch[0].samples, [g, 0.0, 0.0, g, 2.0 * g, 0.0, 0.0, g]);
        assert_eq!(ch[1].samples, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        let rec = crate::channels::assemble("r", ch, &[], None, Some(600.0)).unwrap();
        assert_eq!(rec.channels[0].name, "DE");
        assert!((rec.channels[0].samples[4] - 2.0).abs() < 1e-6);
    }

    #[test]
    fn big_endian_and_integer_channels() {
        let mut raw = Vec::new();
        for v in [-2i16, 300] {
            raw.extend(v.to_be_bytes());
        }
        let seg = Seg {
            toc: TOC_META | TOC_RAW | TOC_NEW_LIST | TOC_BIG_ENDIAN,
            objects: vec![("/'a'/'x'".into(), Some((2, 2)), vec![])],
            raw,
        };
        let ch = parse_tdms(&seg.bytes()).unwrap();
        assert_eq!(ch[0].samples, [-2.0, 300.0]);
        assert_eq!(ch[0].fs_hz, None);
    }

    #[test]
    fn every_truncation_and_bad_byte_is_an_error_never_a_panic() {
        let good = sample_file();
        for n in 0..good.len() {
            // A cut at a segment boundary is a shorter valid file; anywhere else an
            // error.
            if let Ok(ch) = parse_tdms(&good[..n]) {
                assert!(ch.iter().all(|c| c.samples.len() % 2 == 0));
            }
        }
        for i in 0..good.len() {
            let mut bad = good.clone();
            bad[i] ^= 0xA5;
            let _ = parse_tdms(&bad);
        }
        assert!(matches!(parse_tdms(b"TDSh"), Err(TdmsError::Format { .. })));
        let strings = Seg {
            toc: TOC_META | TOC_RAW | TOC_NEW_LIST,
            objects: vec![("/'a'/'s'".into(), Some((0x20, 1)), vec![])],
            raw: vec![],
        };
        assert!(matches!(
            parse_tdms(&strings.bytes()),
            Err(TdmsError::Unsupported { .. })
        ));
        let scaled = Seg {
            toc: TOC_META | TOC_RAW | TOC_NEW_LIST,
            objects: vec![(
                "/'a'/'c'".into(),
                Some((2, 1)),
                vec![("NI_Number_Of_Scales".into(), 7, 2u32.to_le_bytes().to_vec())],
            )],
            raw: vec![1, 0],
        };
        assert!(matches!(
            parse_tdms(&scaled.bytes()),
            Err(TdmsError::Unsupported { .. })
        ));
        // Scaling properties on data that says it is scaled already are no obstacle.
        let already = Seg {
            toc: TOC_META | TOC_RAW | TOC_NEW_LIST,
            objects: vec![(
                "/'a'/'c'".into(),
                Some((10, 1)),
                vec![
                    ("NI_Number_Of_Scales".into(), 7, 2u32.to_le_bytes().to_vec()),
                    str_prop("NI_Scaling_Status", "scaled"),
                ],
            )],
            raw: 0.5f64.to_le_bytes().to_vec(),
        };
        assert_eq!(parse_tdms(&already.bytes()).unwrap()[0].samples, [0.5]);
        // A count with no raw bytes: no data, not an empty channel.
        let none = Seg {
            toc: TOC_META | TOC_RAW | TOC_NEW_LIST,
            objects: vec![("/'a'/'c'".into(), Some((9, 4)), vec![])],
            raw: vec![],
        };
        assert!(parse_tdms(&none.bytes()).unwrap().is_empty());
        let ragged = Seg {
            toc: TOC_META | TOC_RAW | TOC_NEW_LIST,
            objects: vec![("/'a'/'c'".into(), Some((9, 2)), vec![])],
            raw: le_f32(&[1.0, 2.0, 3.0]),
        };
        assert!(matches!(
            parse_tdms(&ragged.bytes()),
            Err(TdmsError::Format { .. })
        ));
    }

    #[test]
    fn paths_split_with_escaped_quotes() {
        assert_eq!(
            path_parts("/'g''s'/'c/1'"),
            Some(vec!["g's".to_string(), "c/1".to_string()])
        );
        assert_eq!(path_parts("/"), Some(vec![]));
        assert_eq!(path_parts("/'open"), None);
        assert_eq!(path_parts("g"), None);
    }

    /// Fuzz finding: a denormal `wf_increment` made an infinite rate.
    #[test]
    fn a_step_whose_rate_overflows_is_refused() {
        let seg = Seg {
            toc: TOC_META | TOC_RAW | TOC_NEW_LIST,
            objects: vec![(
                "/'a'/'c'".into(),
                Some((9, 1)),
                vec![f64_prop("wf_increment", 1e-320)],
            )],
            raw: le_f32(&[1.0]),
        };
        assert!(matches!(
            parse_tdms(&seg.bytes()),
            Err(TdmsError::Format { .. })
        ));
    }
}
