//! Universal file format data set 58 (function at nodal DOF), ASCII and binary (58b),
//! as modal and vibration software (LMS/Simcenter, ME'scope, m+p, pyuff) writes time
//! records. Our own parser, from the I-DEAS universal file format description.
//!
//! ```text
//! blocks between lines "    -1": the block's first line is its data-set number;
//! "58b" adds byte order (1 little, 2 big), float format (2 = IEEE 754), the count of
//! ASCII lines (11) and the bytes of binary data that follow them
//! data set 58: record 1 (ID line 1: the channel's name), 2–5 (ID lines),
//!   6  function type (1 = time response; 0 general) and response node/direction,
//!   7  ordinate type (2 real single, 4 real double), value count, spacing
//!      (1 even), abscissa minimum and increment Δt,
//!   8  abscissa characteristics (17 = time; unit label: s or ms),
//!   9  ordinate characteristics (unit label → the channel's unit), 10–11,
//!   12 values: free-format numbers (pyuff 6E13.5 / 4E20.11), or n × 4 / 8 bytes
//! → one FileChannel per data set 58: name (ID line 1, else node and direction),
//!   unit, rate 1/Δt, samples; every other data set (units, nodes, …) skipped
//! ```
//!
//! The increment is printed with 6 significant digits (E13.5), so 1/Δt is only known
//! to a few parts per million: a rate that lies within that precision of a whole
//! number of hertz is taken as that number (12 000 Hz is written 8.33333e-05 s, whose
//! reciprocal is 12 000.005 Hz; resampling a record by 0.4 ppm would be a fiction).
//!
//! Refused with a named error: a function that is not a time record (spectra,
//! FRFs), complex ordinates, uneven abscissa spacing, a count that disagrees with
//! the values, a non-IEEE binary float format, a block never closed by `-1`.

use crate::channels::FileChannel;

/// What can go wrong reading a UFF file.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum UffError {
    /// A structure is malformed or cut short.
    #[error("malformed UFF at line {line}: {reason}")]
    Format {
        /// 1-based line (of the ASCII text; binary data counts as one).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// A valid data set 58 this reader does not read.
    #[error("data set 58 `{name}` at line {line}: {what}")]
    Unsupported {
        /// The set's ID line 1.
        name: String,
        /// Its first line.
        line: usize,
        /// What it holds.
        what: String,
    },
    /// The file holds no data set 58.
    #[error("no data set 58 (a time record) in the file")]
    NoRecords,
}

/// A cursor over lines that can also take raw bytes (58b).
struct Lines<'a> {
    bytes: &'a [u8],
    at: usize,
    line: usize,
}

impl<'a> Lines<'a> {
    fn next_line(&mut self) -> Option<&'a [u8]> {
        if self.at >= self.bytes.len() {
            return None;
        }
        let rest = &self.bytes[self.at..];
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        self.at += (end + 1).min(rest.len());
        self.line += 1;
        let l = &rest[..end];
        Some(l.strip_suffix(b"\r").unwrap_or(l))
    }

    fn err(&self, reason: impl Into<String>) -> UffError {
        UffError::Format {
            line: self.line,
            reason: reason.into(),
        }
    }

    fn text(&mut self, what: &str) -> Result<&'a str, UffError> {
        let l = self
            .next_line()
            .ok_or_else(|| self.err(format!("the file ends before {what}")))?;
        std::str::from_utf8(l).map_err(|_| self.err(format!("{what} is not text")))
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], UffError> {
        if n > self.bytes.len() - self.at {
            return Err(self.err(format!(
                "{n} bytes of binary data announced, {} left",
                self.bytes.len() - self.at
            )));
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        self.line += 1;
        Ok(s)
    }
}

/// Whether a line is a block delimiter.
fn is_delimiter(l: &[u8]) -> bool {
    l.trim_ascii() == b"-1"
}

/// Fixed-column field `[from, to)` of a line, trimmed ("" past its end).
fn field(l: &str, from: usize, to: usize) -> &str {
    let to = to.min(l.len());
    l.get(from.min(to)..to).unwrap_or("").trim()
}

/// The `k`-th whitespace-separated integer of a line.
fn int(l: &str, k: usize, lines: &Lines<'_>, what: &str) -> Result<i64, UffError> {
    l.split_ascii_whitespace()
        .nth(k)
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| lines.err(format!("{what}: expected an integer in `{}`", l.trim())))
}

/// The header of a data set 58, records 1–11.
#[derive(Debug)]
struct Header {
    name: String,
    first_line: usize,
    double: bool,
    count: usize,
    dt: f64,
    unit: Option<String>,
}

/// Parse records 1–11 of a data set 58.
fn header(lines: &mut Lines<'_>) -> Result<Header, UffError> {
    let first_line = lines.line + 1;
    let id1 = lines.text("record 1")?.trim().to_string();
    for what in ["record 2", "record 3", "record 4", "record 5"] {
        lines.text(what)?;
    }
    let r6 = lines.text("record 6")?;
    let func = int(r6, 0, lines, "record 6 (function type)")?;
    let node = field(r6, 41, 51).to_string();
    let dir = field(r6, 51, 55).to_string();
    let name = match id1.as_str() {
        "" | "NONE" => format!("{node}:{dir}"),
        _ => id1,
    };
    let unsupported = |what: String| UffError::Unsupported {
        name: name.clone(),
        line: first_line,
        what,
    };
    if func != 0 && func != 1 {
        return Err(unsupported(format!(
            "function type {func} is not a time response (1)"
        )));
    }
    let r7 = lines.text("record 7")?;
    let ord = int(r7, 0, lines, "record 7 (ordinate type)")?;
    let count = int(r7, 1, lines, "record 7 (value count)")?;
    let even = int(r7, 2, lines, "record 7 (spacing)")?;
    let dt: f64 = r7
        .split_ascii_whitespace()
        .nth(4)
        .and_then(|t| t.replace(['D', 'd'], "E").parse().ok())
        .ok_or_else(|| lines.err("record 7: no abscissa increment"))?;
    let double = match ord {
        2 => false,
        4 => true,
        5 | 6 => return Err(unsupported("complex ordinate values".into())),
        o => return Err(lines.err(format!("record 7: ordinate type {o} (2 or 4 expected)"))),
    };
    if even != 1 {
        return Err(unsupported("uneven abscissa spacing".into()));
    }
    let count =
        usize::try_from(count).map_err(|_| lines.err(format!("record 7: value count {count}")))?;
    let r8 = lines.text("record 8")?;
    let abscissa = int(r8, 0, lines, "record 8 (abscissa type)")?;
    if abscissa != 0 && abscissa != 17 {
        return Err(unsupported(format!(
            "abscissa of data type {abscissa} is not time (17)"
        )));
    }
    let dt = match field(r8, 47, 67).to_ascii_lowercase().as_str() {
        "" | "none" | "s" | "sec" | "second" | "seconds" => dt,
        "ms" => dt * 1e-3,
        u => return Err(unsupported(format!("abscissa unit `{u}`"))),
    };
    // A denormal step would make an infinite rate, an infinite one a zero rate.
    if !(dt.is_finite() && dt > 0.0 && (1.0 / dt).is_finite()) {
        return Err(unsupported(format!("abscissa increment {dt} s")));
    }
    let r9 = lines.text("record 9")?;
    let unit = match field(r9, 47, 67) {
        "" | "NONE" => None,
        u => Some(u.to_string()),
    };
    lines.text("record 10")?;
    lines.text("record 11")?;
    Ok(Header {
        name,
        first_line,
        double,
        count,
        dt,
        unit,
    })
}

/// The rate 1/Δt, a whole number of hertz where the increment of that rate prints
/// as the file's Δt with E13.5's 6 significant digits (module docs).
fn rate(dt: f64) -> f64 {
    let whole = (1.0 / dt).round();
    let half_digit = 0.5 * 10f64.powf(dt.log10().floor() - 5.0);
    if whole > 0.0 && (1.0 / whole - dt).abs() <= half_digit * (1.0 + 1e-9) {
        whole
    } else {
        1.0 / dt
    }
}

/// The ASCII values of a data set 58, up to its closing `-1`.
fn ascii_values(lines: &mut Lines<'_>, h: &Header) -> Result<Vec<f32>, UffError> {
    let mut out = Vec::with_capacity(h.count.min(1 << 24));
    loop {
        let l = lines
            .next_line()
            .ok_or_else(|| lines.err(format!("data set 58 `{}` is never closed by -1", h.name)))?;
        if is_delimiter(l) {
            break;
        }
        let text = std::str::from_utf8(l).map_err(|_| lines.err("a value line is not text"))?;
        for t in text.split_ascii_whitespace() {
            let v: f64 = t
                .replace(['D', 'd'], "E")
                .parse()
                .map_err(|_| lines.err(format!("`{t}` is not a number")))?;
            out.push(v as f32);
        }
    }
    Ok(out)
}

/// The binary values of a data set 58b: `n_bytes` raw, then the closing `-1`.
fn binary_values(
    lines: &mut Lines<'_>,
    h: &Header,
    big: bool,
    n_bytes: usize,
) -> Result<Vec<f32>, UffError> {
    let size = if h.double { 8 } else { 4 };
    let raw = lines.take(n_bytes)?;
    if n_bytes % size != 0 {
        return Err(lines.err(format!("{n_bytes} bytes are not whole {size}-byte values")));
    }
    let values = raw
        .chunks_exact(size)
        .map(|b| {
            let mut a = [0u8; 8];
            a[..size].copy_from_slice(b);
            if big {
                a[..size].reverse();
            }
            if h.double {
                f64::from_le_bytes(a) as f32
            } else {
                f32::from_le_bytes([a[0], a[1], a[2], a[3]])
            }
        })
        .collect();
    // Some writers end the binary data with a line break before the delimiter.
    let mut closing = lines.next_line();
    if closing == Some(b"") {
        closing = lines.next_line();
    }
    match closing {
        Some(l) if is_delimiter(l) => Ok(values),
        _ => Err(lines.err(format!("data set 58b `{}` is not closed by -1", h.name))),
    }
}

/// The `58b` fields of a binary header line: byte order big, bytes of data.
fn binary_layout(l: &str, lines: &Lines<'_>) -> Result<(bool, usize), UffError> {
    let order = int(l, 1, lines, "58b byte order")?;
    let float = int(l, 2, lines, "58b float format")?;
    let ascii = int(l, 3, lines, "58b ASCII line count")?;
    let n_bytes = int(l, 4, lines, "58b byte count")?;
    if float != 2 {
        return Err(lines.err(format!("58b float format {float} is not IEEE 754 (2)")));
    }
    if ascii != 11 {
        return Err(lines.err(format!("58b with {ascii} ASCII lines (11 expected)")));
    }
    let big = match order {
        1 => false,
        2 => true,
        o => return Err(lines.err(format!("58b byte order {o} (1 or 2 expected)"))),
    };
    let n_bytes = usize::try_from(n_bytes).map_err(|_| lines.err("58b byte count"))?;
    Ok((big, n_bytes))
}

/// Skip an unread data set: to its `-1` (ASCII), or over its ASCII lines and bytes
/// (binary, with the same header layout as 58b).
fn skip_set(lines: &mut Lines<'_>, id_line: &str) -> Result<(), UffError> {
    if id_line
        .trim_start()
        .split_ascii_whitespace()
        .next()
        .is_some_and(|t| t.ends_with('b'))
    {
        let ascii = int(id_line, 3, lines, "binary set's ASCII line count")?;
        let n_bytes = int(id_line, 4, lines, "binary set's byte count")?;
        for _ in 0..ascii.max(0) {
            lines.text("a header line")?;
        }
        lines.take(usize::try_from(n_bytes).map_err(|_| lines.err("byte count"))?)?;
    }
    loop {
        match lines.next_line() {
            Some(l) if is_delimiter(l) => return Ok(()),
            Some(_) => {}
            None => return Err(lines.err("a data set is never closed by -1")),
        }
    }
}

/// The time records of a universal file (module docs).
pub fn parse_uff(bytes: &[u8]) -> Result<Vec<FileChannel>, UffError> {
    let mut lines = Lines {
        bytes,
        at: 0,
        line: 0,
    };
    let mut out = Vec::new();
    while let Some(l) = lines.next_line() {
        if l.trim_ascii().is_empty() {
            continue;
        }
        if !is_delimiter(l) {
            return Err(lines.err("expected -1 before a data set"));
        }
        let id_line = lines.text("a data-set number")?;
        let id = id_line.split_ascii_whitespace().next().unwrap_or("");
        match id {
            "58" | "58b" => {
                let layout = match id {
                    "58b" => Some(binary_layout(id_line, &lines)?),
                    _ => None,
                };
                let h = header(&mut lines)?;
                let samples = match layout {
                    Some((big, n_bytes)) => binary_values(&mut lines, &h, big, n_bytes)?,
                    None => ascii_values(&mut lines, &h)?,
                };
                if samples.len() != h.count {
                    return Err(UffError::Unsupported {
                        name: h.name,
                        line: h.first_line,
                        what: format!("{} values where record 7 says {}", samples.len(), h.count),
                    });
                }
                out.push(FileChannel {
                    name: h.name,
                    unit: h.unit,
                    fs_hz: Some(rate(h.dt)),
                    samples,
                });
            }
            _ => skip_set(&mut lines, id_line)?,
        }
    }
    if out.is_empty() {
        return Err(UffError::NoRecords);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A data set 58 as pyuff lays it out (ASCII single or binary double).
    fn set58(name: &str, values: &[f64], dt: f64, unit: &str, binary: bool) -> Vec<u8> {
        let mut s = String::from("    -1\n");
        let n_bytes = values.len() * 8;
        if binary {
            s += &format!(
                "    58b{:6}{:6}{:12}{:12}{:6}{:6}{:12}{:12}\n",
                1, 2, 11, n_bytes, 0, 0, 0, 0
            );
        } else {
            s += &format!("{:6}{:74}\n", 58, "");
        }
        s += &format!("{name:<80}\nid2\nNONE\nNONE\nNONE\n");
        s += &format!(
            "{:5}{:10}{:5}{:10} {:>10}{:10}{:4} {:>10}{:10}{:4}\n",
            1, 0, 0, 0, "NONE", 7, 3, "NONE", 0, 0
        );
        let ord = if binary { 4 } else { 2 };
        s += &format!(
            "{ord:10}{:10}{:10}{:13.5e}{:13.5e}{:13.5e}\n",
            values.len(),
            1,
            0.0,
            dt,
            0.0
        );
        s += &format!(
            "{:10}{:5}{:5}{:5} {:<20} {:<20}\n",
            17, 0, 0, 0, "NONE", "s"
        );
        s += &format!(
            "{:10}{:5}{:5}{:5} {:<20} {:<20}\n",
            12, 0, 0, 0, "NONE", unit
        );
        s += &format!(
            "{:10}{:5}{:5}{:5} {:<20} {:<20}\n",
            13, 0, 0, 0, "NONE", "NONE"
        );
        s += &format!(
            "{:10}{:5}{:5}{:5} {:<20} {:<20}\n",
            0, 0, 0, 0, "NONE", "NONE"
        );
        let mut out = s.into_bytes();
        if binary {
            values.iter().for_each(|v| out.extend(v.to_le_bytes()));
        } else {
            for row in values.chunks(6) {
                let line: String = row.iter().map(|v| format!("{v:13.5e}")).collect();
                out.extend(line.as_bytes());
                out.push(b'\n');
            }
        }
        out.extend(b"    -1\n");
        out
    }

    fn units_set() -> Vec<u8> {
        b"    -1\n   164\n         1  SI: Meter (newton)         2\n    1.00000000000000000E+00\n    -1\n"
            .to_vec()
    }

    #[test]
    fn ascii_and_binary_sets_become_channels() {
        let de: Vec<f64> = (0..13).map(|i| (f64::from(i) * 0.3).sin()).collect();
        let fe: Vec<f64> = de.iter().map(|v| -2.0 * v).collect();
        for binary in [false, true] {
            let file = [
                units_set(),
                set58("DE", &de, 1.0 / 12_000.0, "g", binary),
                set58("FE accel", &fe, 1.0 / 12_000.0, "m/s^2", binary),
            ]
            .concat();
            let ch = parse_uff(&file).unwrap();
            assert_eq!(ch.len(), 2);
            assert_eq!(ch[0].name, "DE");
            assert_eq!(ch[0].fs_hz, Some(12_000.0), "snapped to whole hertz");
            assert_eq!(ch[1].unit.as_deref(), Some("m/s^2"));
            for (a, b) in ch[1].samples.iter().zip(&fe) {
                assert!((f64::from(*a) - b).abs() < 1e-5, "{binary}");
            }
            let rec = crate::channels::assemble("r", ch, &[], None, None).unwrap();
            assert_eq!(rec.channels[1].name, "FE");
        }
        // 25.6 kHz stays; 1/3 ms a rate of 3 kHz; a non-whole rate is kept.
        assert_eq!(rate(1.0 / 25_600.0), 25_600.0);
        assert_eq!(rate(3.90625e-5), 25_600.0);
        assert_eq!(rate(1.0 / 48_828.125), 48_828.125);
        assert_eq!(
            rate(2.04800e-05),
            48_828.125,
            "MFPT's rate printed in E13.5"
        );
        assert_eq!(rate(8.33333e-05), 12_000.0);
    }

    #[test]
    fn what_is_not_a_time_record_is_refused_by_name() {
        let good = set58("DE", &[0.1, 0.2, 0.3], 1e-4, "g", false);
        let text = String::from_utf8(good.clone()).unwrap();
        let spectrum = text.replacen("    1         0", "    2         0", 1);
        assert!(matches!(
            parse_uff(spectrum.as_bytes()),
            Err(UffError::Unsupported { .. })
        ));
        let freq = text.replacen("        17", "        18", 1);
        assert!(matches!(
            parse_uff(freq.as_bytes()),
            Err(UffError::Unsupported { .. })
        ));
        let short = text.replacen("         3         1", "         4         1", 1);
        assert!(matches!(
            parse_uff(short.as_bytes()),
            Err(UffError::Unsupported { .. })
        ));
        // Fuzz finding: an infinite Δt made a zero rate.
        for dt in ["inf", "1e-320", "0.0", "-1e-4"] {
            let bad = text.replacen("1.00000e-4", dt, 1);
            assert!(
                matches!(parse_uff(bad.as_bytes()), Err(UffError::Unsupported { .. })),
                "{dt}"
            );
        }
        let nan = text.replacen("2.00000e-1", "NaN", 1);
        let ch = parse_uff(nan.as_bytes()).unwrap();
        assert!(crate::channels::assemble("r", ch, &[], None, None).is_err());
        assert_eq!(parse_uff(&units_set()), Err(UffError::NoRecords));
        assert!(matches!(parse_uff(b"58\n"), Err(UffError::Format { .. })));
    }

    #[test]
    fn every_truncation_is_an_error_never_a_panic() {
        let file = [
            set58("DE", &[0.1, 0.2, 0.3], 1e-4, "g", true),
            set58("FE", &[0.1, 0.2, 0.3], 1e-4, "g", false),
        ]
        .concat();
        assert!(parse_uff(&file).is_ok());
        for n in 0..file.len() {
            if let Ok(ch) = parse_uff(&file[..n]) {
                // Only a cut after a set's closing -1 (or its line break) reads.
                assert!(ch.iter().all(|c| c.samples.len() == 3), "{n}");
            }
        }
        for i in 0..file.len() {
            let mut bad = file.clone();
            bad[i] = bad[i].wrapping_add(17);
            let _ = parse_uff(&bad);
        }
    }
}
