//! CSV recordings: a header row of channel names, then one column per channel and
//! one row per sample instant.
//!
//! ```text
//! # optional comment lines, anywhere
//! DE,FE,BA
//! 0.0132,-0.0410,0.0051
//! ...
//! ```
//!
//! The delimiter (comma, semicolon or tab) is detected from the header row and then
//! required on every row. A file with a single column has no delimiter at all.
//!
//! A column names a sensor when its name is `DE`, `FE` or `BA` in any case, alone or
//! as one `_`/`-`/space/`.`-separated token of a longer name (`de`, `DE_time`,
//! `X105_DE_time`, `fe accel`); the channel then carries the sensor's name. Names
//! with none of the three, or with two, keep their own (and so do two columns that
//! would both become the same sensor). A header whose cells are all numbers is a
//! missing header, not channel names.
//!
//! A sensor column may declare its unit at the end of its name, in brackets or
//! parentheses (`DE [g]`, `FE (m/s^2)`, `BA [mg]`, `DE_acc[m/s²]`): the samples are
//! converted to g, the unit every model and the twin work in (g, mg, m/s², mm/s²;
//! 1 g = 9.80665 m/s²). A sensor column with any other unit (`DE [V]`) is an error, as
//! it is not an acceleration; without a unit the samples are taken as g.
//!
//! The sampling rate and the shaft speed are never guessed (a wrong one silently
//! distorts every frequency feature): they come from the caller (CLI flags) or from the
//! file's own declaration, `key=value` tokens on the comment lines before the header,
//! as `pumptwin twin generate` and `simulate` write them:
//!
//! ```text
//! # fs_hz=12000 rpm=1797
//! DE
//! ```
//!
//! Keys `fs_hz` and `rpm` in any case (other keys are free text); a declared value
//! that is not a positive finite number, a key declared twice with different values,
//! or a flag that disagrees with the declaration (by more than 0.1 %) is an error —
//! one of the two is wrong, and the loader cannot know which. There are no defaults:
//! a file with no rate and no `--fs` is an error. Every cell must be a finite number: a blank, text, NaN or infinite
//! cell is an error that names the line and the column, never a skipped row, because a
//! dropped sample shifts the time base of everything after it.

use std::path::Path;

use crate::channels::{g_per_unit, sensor_names, SENSORS};
use crate::recording::{Channel, Recording};

/// Errors reading a CSV recording.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    /// No header row (the file is empty or only comments).
    #[error("no header row (the file is empty or holds only comments)")]
    MissingHeader,
    /// A header cell is empty or repeated.
    #[error("header: {reason}")]
    BadHeader {
        /// What is wrong.
        reason: String,
    },
    /// A row has a different number of cells than the header.
    #[error("line {line}: {got} cells, but the header names {expected} channels (delimiter {delimiter:?})")]
    Ragged {
        /// 1-based line number in the file.
        line: usize,
        /// Number of header columns.
        expected: usize,
        /// Cells on this line.
        got: usize,
        /// The detected delimiter.
        delimiter: char,
    },
    /// A cell is not a number.
    #[error("line {line}, column `{column}`: {cell:?} is not a number")]
    NotANumber {
        /// 1-based line number in the file.
        line: usize,
        /// Header name of the column.
        column: String,
        /// The cell text.
        cell: String,
    },
    /// A cell is NaN or infinite (or overflows `f32`).
    #[error("line {line}, column `{column}`: {cell:?} is not finite")]
    NonFinite {
        /// 1-based line number in the file.
        line: usize,
        /// Header name of the column.
        column: String,
        /// The cell text.
        cell: String,
    },
    /// The header is there but no data rows follow.
    #[error("no data rows after the header")]
    NoRows,
    /// Sampling rate or speed is not a positive finite number.
    #[error("{what} must be a positive finite number, got {value}")]
    InvalidParameter {
        /// `fs_hz` or `rpm`.
        what: &'static str,
        /// The value given.
        value: f32,
    },
    /// Neither the caller nor the file gives the sampling rate.
    #[error(
        "sampling rate unknown: pass it explicitly (e.g. --fs 12000) or declare it on a \
         comment line before the header (`# fs_hz=12000 rpm=1797`)"
    )]
    MissingSamplingRate,
    /// A `fs_hz=`/`rpm=` declaration in the comments before the header is unusable.
    #[error("line {line}: declaration {token:?}: {reason}")]
    BadDeclaration {
        /// 1-based line number in the file.
        line: usize,
        /// The `key=value` token.
        token: String,
        /// What is wrong.
        reason: &'static str,
    },
    /// The caller's value and the file's declaration disagree.
    #[error(
        "the file declares {what}={declared}, but {given} was given: one of them is wrong \
         (drop the flag or correct the file)"
    )]
    Disagrees {
        /// `fs_hz` or `rpm`.
        what: &'static str,
        /// The file's value.
        declared: f32,
        /// The caller's value.
        given: f32,
    },
}

/// What a file declares about itself before its header (module docs).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct Declared {
    fs_hz: Option<f32>,
    rpm: Option<f32>,
}

/// Two values of one quantity agree within 0.1 % (a rate or speed rounded in a header).
fn agree(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-3 * a.max(b)
}

/// The `fs_hz=` and `rpm=` tokens of the comment lines before the header.
fn declarations(text: &str) -> Result<Declared, CsvError> {
    let mut declared = Declared::default();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start_matches('\u{feff}').trim();
        if t.is_empty() {
            continue;
        }
        let Some(comment) = t.strip_prefix('#') else {
            break; // the header: declarations end there
        };
        // `fs_hz = 12000` is `fs_hz=12000`.
        let mut comment = comment.to_string();
        while comment.contains(" =") || comment.contains("= ") {
            comment = comment.replace(" =", "=").replace("= ", "=");
        }
        for token in comment.split(|c: char| c.is_whitespace() || c == ',' || c == ';') {
            let Some((key, value)) = token.split_once('=') else {
                continue;
            };
            let (what, slot) = match key.to_ascii_lowercase().as_str() {
                "fs_hz" => ("fs_hz", &mut declared.fs_hz),
                "rpm" => ("rpm", &mut declared.rpm),
                _ => continue,
            };
            let bad = |reason| CsvError::BadDeclaration {
                line: i + 1,
                token: token.to_string(),
                reason,
            };
            let v = value
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or_else(|| bad("not a positive finite number"))?;
            if slot.is_some_and(|prev| !agree(prev, v)) {
                return Err(bad(if what == "fs_hz" {
                    "fs_hz declared twice with different values"
                } else {
                    "rpm declared twice with different values"
                }));
            }
            *slot = Some(v);
        }
    }
    Ok(declared)
}

/// The caller's value, checked, else the file's; both given must agree.
fn resolve(
    what: &'static str,
    given: Option<f32>,
    declared: Option<f32>,
) -> Result<Option<f32>, CsvError> {
    match (given, declared) {
        (Some(value), _) if !(value.is_finite() && value > 0.0) => {
            Err(CsvError::InvalidParameter { what, value })
        }
        (Some(given), Some(declared)) if !agree(given, declared) => Err(CsvError::Disagrees {
            what,
            declared,
            given,
        }),
        (given, declared) => Ok(given.or(declared)),
    }
}

/// Pick the delimiter from the header row: the most frequent of `,`, `;`, tab;
/// `None` when the header has none of them (a single channel).
fn detect_delimiter(header: &str) -> Option<char> {
    [',', ';', '\t']
        .into_iter()
        .map(|d| (header.matches(d).count(), d))
        .filter(|(n, _)| *n > 0)
        .max_by_key(|(n, _)| *n)
        .map(|(_, d)| d)
}

/// Split a line into trimmed cells (no delimiter → one cell).
fn cells(line: &str, delimiter: Option<char>) -> Vec<&str> {
    match delimiter {
        Some(d) => line.split(d).map(str::trim).collect(),
        None => vec![line.trim()],
    }
}

/// Parse CSV text into a [`Recording`] named `name`: sampling rate and shaft speed from
/// the caller (`fs_hz`, `rpm`) or the file's declaration (module docs).
pub fn parse_csv(
    text: &str,
    name: &str,
    fs_hz: Option<f32>,
    rpm: Option<f32>,
) -> Result<Recording, CsvError> {
    let declared = declarations(text)?;
    let fs_hz = resolve("fs_hz", fs_hz, declared.fs_hz)?.ok_or(CsvError::MissingSamplingRate)?;
    let rpm = resolve("rpm", rpm, declared.rpm)?;
    let mut lines = content_lines(text);
    let (_, header) = lines.next().ok_or(CsvError::MissingHeader)?;
    let (delimiter, names) = header_names(header);
    for (i, n) in names.iter().enumerate() {
        if n.is_empty() {
            return Err(CsvError::BadHeader {
                reason: format!("column {} has no name", i + 1),
            });
        }
        if names[..i].contains(n) {
            return Err(CsvError::BadHeader {
                reason: format!("channel name `{n}` appears twice"),
            });
        }
    }
    if names.iter().all(|n| n.parse::<f64>().is_ok()) {
        return Err(CsvError::BadHeader {
            reason: format!(
                "the first row ({header:?}) is numbers: a CSV needs a header row naming the \
                 channels (DE, FE, BA)"
            ),
        });
    }
    let (names, scales) = units_to_g(names)?;
    let mut columns: Vec<Vec<f32>> = vec![Vec::new(); names.len()];
    for (line, text) in lines {
        let row = cells(text, delimiter);
        if row.len() != names.len() {
            return Err(CsvError::Ragged {
                line,
                expected: names.len(),
                got: row.len(),
                delimiter: delimiter.unwrap_or(','),
            });
        }
        for (((cell, column), name), scale) in row
            .into_iter()
            .zip(columns.iter_mut())
            .zip(&names)
            .zip(&scales)
        {
            let value: f64 = cell.parse().map_err(|_| CsvError::NotANumber {
                line,
                column: name.clone(),
                cell: cell.to_string(),
            })?;
            let value = (value * scale) as f32;
            if !value.is_finite() {
                return Err(CsvError::NonFinite {
                    line,
                    column: name.clone(),
                    cell: cell.to_string(),
                });
            }
            column.push(value);
        }
    }
    if columns.first().is_none_or(Vec::is_empty) {
        return Err(CsvError::NoRows);
    }
    Ok(Recording {
        name: name.to_string(),
        fs_hz,
        rpm,
        channels: names
            .into_iter()
            .zip(columns)
            .map(|(name, samples)| Channel { name, samples })
            .collect(),
    })
}

/// The lines that are not blank or comments, with their 1-based numbers.
fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| {
            let t = l.trim_start();
            !t.is_empty() && !t.starts_with('#')
        })
}

/// The header row's delimiter and column names (a leading byte-order mark and
/// quotes around names removed).
fn header_names(header: &str) -> (Option<char>, Vec<String>) {
    let header = header.trim_start_matches('\u{feff}');
    let delimiter = detect_delimiter(header);
    let names = cells(header, delimiter)
        .into_iter()
        .map(|c| c.trim_matches('"').to_string())
        .collect();
    (delimiter, names)
}

/// A column name split into its name and the unit it declares at its end, in
/// brackets or parentheses (`DE [m/s^2]` → `DE`, `m/s^2`).
fn split_unit(name: &str) -> (&str, Option<&str>) {
    let t = name.trim_end();
    for (open, close) in [('[', ']'), ('(', ')')] {
        if let Some(inner) = t.strip_suffix(close) {
            if let Some(at) = inner.rfind(open) {
                let base = inner[..at].trim_end_matches([' ', '_', '-', '.']);
                if !base.is_empty() {
                    return (base, Some(inner[at + 1..].trim()));
                }
            }
        }
    }
    (t, None)
}

/// Sensor names (see [`sensor_names`]) and, per column, the factor that brings its
/// samples to g: from the unit a sensor column declares, 1 without one. Columns that
/// are no sensor keep their unit in their name and a factor of 1.
fn units_to_g(names: Vec<String>) -> Result<(Vec<String>, Vec<f64>), CsvError> {
    let split: Vec<(String, Option<String>)> = names
        .iter()
        .map(|n| {
            let (base, unit) = split_unit(n);
            (base.to_string(), unit.map(str::to_string))
        })
        .collect();
    let mapped = sensor_names(split.iter().map(|(b, _)| b.clone()).collect());
    let mut out_names = Vec::with_capacity(names.len());
    let mut scales = Vec::with_capacity(names.len());
    for ((full, (_, unit)), name) in names.iter().zip(&split).zip(mapped) {
        let is_sensor = SENSORS.contains(&name.as_str());
        match (is_sensor, unit) {
            (true, Some(u)) => {
                let scale = g_per_unit(u).ok_or_else(|| CsvError::BadHeader {
                    reason: format!(
                        "column `{full}`: unit `{u}` is not an acceleration (g, mg, m/s², mm/s²)"
                    ),
                })?;
                out_names.push(name);
                scales.push(scale);
            }
            (true, None) => {
                out_names.push(name);
                scales.push(1.0);
            }
            (false, _) => {
                out_names.push(full.clone());
                scales.push(1.0);
            }
        }
    }
    Ok((out_names, scales))
}

/// Whether the CSV at `path` declares the unit of one of its sensor columns (the
/// samples are then converted to g on reading, and a scale given besides would apply
/// twice).
pub fn declares_sensor_units(path: &Path) -> std::io::Result<bool> {
    let text = std::fs::read_to_string(path)?;
    let Some((_, header)) = content_lines(&text).next() else {
        return Ok(false);
    };
    let (_, names) = header_names(header);
    let bases: Vec<String> = names.iter().map(|n| split_unit(n).0.to_string()).collect();
    Ok(names
        .iter()
        .zip(sensor_names(bases))
        .any(|(n, s)| SENSORS.contains(&s.as_str()) && split_unit(n).1.is_some()))
}

/// Name a recording after its file stem.
pub(crate) fn stem_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_channels_with_each_delimiter() {
        for d in [",", ";", "\t"] {
            let text =
                format!("# pump P-101, bearing 6205\nDE{d}FE\n1.5{d}-2\n# pause\n\n3e-3{d} 4 \r\n");
            let rec = parse_csv(&text, "p101", Some(25_600.0), Some(2950.0)).expect("valid csv");
            assert_eq!(rec.fs_hz, 25_600.0);
            assert_eq!(rec.rpm, Some(2950.0));
            assert_eq!(rec.channels.len(), 2);
            assert_eq!(rec.channels[0].name, "DE");
            assert_eq!(rec.channels[0].samples, vec![1.5, 3e-3]);
            assert_eq!(rec.channels[1].name, "FE");
            assert_eq!(rec.channels[1].samples, vec![-2.0, 4.0]);
        }
    }

    #[test]
    fn single_column_and_quoted_header() {
        let rec = parse_csv("\"acc\"\n1\n2\n3\n", "x", Some(1000.0), None).expect("valid");
        assert_eq!(rec.channels.len(), 1);
        assert_eq!(rec.channels[0].name, "acc");
        assert_eq!(rec.channels[0].samples, vec![1.0, 2.0, 3.0]);
    }

    #[test]
    fn bad_cells_name_line_and_column() {
        let err = parse_csv("DE,FE\n1,2\n3,abc\n", "x", Some(1000.0), None).expect_err("text cell");
        assert!(
            matches!(&err, CsvError::NotANumber { line: 3, column, .. } if column == "FE"),
            "{err}"
        );
        for bad in ["NaN", "inf", "-Infinity", "1e40"] {
            let err =
                parse_csv(&format!("DE,FE\n{bad},2\n"), "x", Some(1000.0), None).expect_err(bad);
            assert!(
                matches!(&err, CsvError::NonFinite { line: 2, column, .. } if column == "DE"),
                "{err}"
            );
        }
        let err = parse_csv("DE,FE\n1,2\n\n3\n", "x", Some(1000.0), None).expect_err("ragged");
        assert!(
            matches!(
                err,
                CsvError::Ragged {
                    line: 4,
                    expected: 2,
                    got: 1,
                    ..
                }
            ),
            "{err}"
        );
        let err = parse_csv("DE,FE\n1,2,3\n", "x", Some(1000.0), None).expect_err("ragged");
        assert!(matches!(err, CsvError::Ragged { got: 3, .. }), "{err}");
        let err = parse_csv("DE,FE\n1,\n", "x", Some(1000.0), None).expect_err("blank cell");
        assert!(matches!(err, CsvError::NotANumber { .. }), "{err}");
    }

    #[test]
    fn header_and_parameter_errors() {
        assert!(matches!(
            parse_csv("# only\n", "x", Some(1.0), None),
            Err(CsvError::MissingHeader)
        ));
        assert!(matches!(
            parse_csv("DE,FE\n", "x", Some(1.0), None),
            Err(CsvError::NoRows)
        ));
        assert!(matches!(
            parse_csv("DE,DE\n1,2\n", "x", Some(1.0), None),
            Err(CsvError::BadHeader { .. })
        ));
        assert!(matches!(
            parse_csv("DE,\n1,2\n", "x", Some(1.0), None),
            Err(CsvError::BadHeader { .. })
        ));
        assert!(matches!(
            parse_csv("DE\n1\n", "x", Some(0.0), None),
            Err(CsvError::InvalidParameter { what: "fs_hz", .. })
        ));
        assert!(matches!(
            parse_csv("DE\n1\n", "x", Some(1.0), Some(f32::NAN)),
            Err(CsvError::InvalidParameter { what: "rpm", .. })
        ));
    }

    #[test]
    fn the_file_may_declare_its_rate_and_speed() {
        let text = "# pump P-101, bearing 6205\n# fs_hz=12000 RPM = 1797 (nominal)\nDE\n1\n2\n";
        let rec = parse_csv(text, "d", None, None).expect("declared");
        assert_eq!((rec.fs_hz, rec.rpm), (12_000.0, Some(1797.0)));
        // A flag that agrees (within 0.1 %) is fine; the flag's value is used.
        let rec = parse_csv(text, "d", Some(12_000.0), Some(1796.0)).expect("agrees");
        assert_eq!(rec.rpm, Some(1796.0));
        // One that disagrees is an error, as is no rate at all.
        let err = parse_csv(text, "d", Some(48_000.0), None).expect_err("disagrees");
        assert!(
            matches!(err, CsvError::Disagrees { what: "fs_hz", declared, given } if declared == 12_000.0 && given == 48_000.0),
            "{err}"
        );
        let err = parse_csv(text, "d", None, Some(1500.0)).expect_err("rpm disagrees");
        assert!(
            matches!(err, CsvError::Disagrees { what: "rpm", .. }),
            "{err}"
        );
        let err = parse_csv("# rpm=1797\nDE\n1\n", "d", None, None).expect_err("no rate");
        assert!(matches!(err, CsvError::MissingSamplingRate), "{err}");
        assert!(err.to_string().contains("fs_hz=12000"), "{err}");
        // Only the comments before the header declare; later ones are free text.
        let err = parse_csv("DE\n# fs_hz=12000\n1\n", "d", None, None).expect_err("after");
        assert!(matches!(err, CsvError::MissingSamplingRate), "{err}");
        // Unusable declarations name their line.
        for (text, line) in [
            ("# fs_hz=abc\nDE\n1\n", 1),
            ("# c\n# rpm=NaN\nDE\n1\n", 2),
            ("# fs_hz=-5\nDE\n1\n", 1),
            ("# fs_hz=12000\n# fs_hz=48000\nDE\n1\n", 2),
        ] {
            let err = parse_csv(text, "d", None, None).expect_err(text);
            assert!(
                matches!(err, CsvError::BadDeclaration { line: l, .. } if l == line),
                "{text}: {err}"
            );
        }
    }

    #[test]
    fn delimiter_comes_from_the_header() {
        // Semicolon header: a comma inside a cell is not a delimiter, so "1,5" is a bad number.
        let err = parse_csv("DE;FE\n1,5;2\n", "x", Some(1.0), None).expect_err("decimal comma");
        assert!(matches!(err, CsvError::NotANumber { .. }), "{err}");
    }

    #[test]
    fn columns_name_sensors_in_any_case_and_as_tokens() {
        let rec = parse_csv(
            "de;X105_FE_time;Ba accel;temp\n1;2;3;4\n",
            "r",
            Some(12_000.0),
            None,
        )
        .expect("parsed");
        let names: Vec<&str> = rec.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["DE", "FE", "BA", "temp"]);
        // Two columns for one sensor, or one name for two: each keeps its own.
        let rec =
            parse_csv("de,DE_time,DE_FE\n1,2,3\n", "r", Some(12_000.0), None).expect("parsed");
        let names: Vec<&str> = rec.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["de", "DE_time", "DE_FE"]);
        let rec = parse_csv("DE,de_time\n1,2\n", "r", Some(12_000.0), None).expect("parsed");
        let names: Vec<&str> = rec.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["DE", "de_time"]);
    }

    #[test]
    fn declared_units_are_converted_to_g() {
        let rec = parse_csv(
            "DE [m/s^2],FE (mg),BA_acc[g],temp [C]\n9.80665,1000,0.5,20\n-19.6133,-500,1,21\n",
            "u",
            Some(12_000.0),
            None,
        )
        .expect("units");
        let ch = |n: &str| rec.channel(n).expect(n).samples.clone();
        assert!((ch("DE")[0] - 1.0).abs() < 1e-6 && (ch("DE")[1] + 2.0).abs() < 1e-6);
        assert!((ch("FE")[0] - 1.0).abs() < 1e-6 && (ch("FE")[1] + 0.5).abs() < 1e-6);
        assert_eq!(ch("BA"), vec![0.5, 1.0]);
        assert_eq!(
            ch("temp [C]"),
            vec![20.0, 21.0],
            "not a sensor: kept as read"
        );
        for spelling in ["m/s²", "m s^-2", "ms-2", "m·s^-2"] {
            let text = format!("DE [{spelling}]\n9.80665\n");
            let r = parse_csv(&text, "u", Some(1.0), None).expect(spelling);
            assert!(
                (r.channel("DE").expect("DE").samples[0] - 1.0).abs() < 1e-6,
                "{spelling}"
            );
        }
        let err = parse_csv("DE [V]\n1\n", "u", Some(1.0), None).expect_err("volts");
        assert!(err.to_string().contains("not an acceleration"), "{err}");
        // What `twin loop` asks before it applies `--unit-scale` on top.
        let dir = crate::test_support::scratch_dir("csv-units");
        for (header, declared) in [("# c\nDE [mg],temp\n", true), ("DE,temp [C]\n", false)] {
            let path = dir.join("r.csv");
            std::fs::write(&path, format!("{header}1,2\n")).expect("write");
            assert_eq!(
                declares_sensor_units(&path).expect("read"),
                declared,
                "{header}"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_row_of_numbers_is_no_header() {
        let err = parse_csv("0.1,0.2,0.3\n0.4,0.5,0.6\n", "r", Some(12_000.0), None)
            .expect_err("no header");
        assert!(matches!(err, CsvError::BadHeader { .. }), "{err}");
        assert!(err.to_string().contains("header row"), "{err}");
    }
}
