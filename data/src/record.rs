//! A measured recording (channels of samples at one rate) and the loaders that make
//! one from a CWRU `.mat` file or a CSV file.
//!
//! CWRU files name their variables after the file number: `X105_DE_time`,
//! `X105_FE_time`, `X105_BA_time` (drive-end, fan-end and base accelerometers) and
//! `X105RPM`. Some files carry a second record's variables too (99.mat also holds
//! `X098_*`), so variables are picked by the file number; only when nothing matches
//! it (e.g. a renamed file such as `IR007_0.mat`) are they picked by suffix, taking
//! the number that occurs most often so that one record's channels stay together.
//!
//! The sampling rate is not in the `.mat` file; it comes from the caller or from the
//! data set's `MANIFEST.tsv`. The shaft speed comes from the file's `RPM` variable
//! when present (it was measured with the data), else from the caller.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::csv::{parse_csv, stem_name, CsvError};
use crate::manifest::{parse_manifest, ManifestError, MANIFEST_FILE};
use crate::mat::{read_mat, MatError, MatFile, MatVariable};
use crate::recording::check_positive;
pub use crate::recording::{Channel, Recording, RecordingError, CWRU_CHANNELS};

/// Errors loading or checking a recording.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A file could not be read.
    #[error("cannot read {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A `.mat` file is malformed.
    #[error("cannot parse MAT file {}", path.display())]
    Mat {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: MatError,
    },
    /// A CSV file is malformed.
    #[error("cannot parse CSV file {}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: CsvError,
    },
    /// A WAV file is malformed.
    #[error("cannot read WAV file {}", path.display())]
    Wav {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: crate::wav::WavError,
    },
    /// A TDMS file is malformed or holds what this reader does not read.
    #[error("{}: cannot read as TDMS", path.display())]
    Tdms {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: crate::tdms::TdmsError,
    },
    /// A universal file is malformed or holds no time record.
    #[error("{}: cannot read as a universal file (data set 58)", path.display())]
    Uff {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: crate::uff::UffError,
    },
    /// A self-describing file's channels do not make one recording.
    #[error("{}: its channels do not make one recording", path.display())]
    Channels {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: crate::channels::ChannelsError,
    },
    /// A sampling rate given for a file that states its own disagrees with it.
    #[error("{}: --fs {given} Hz disagrees with the file's {file} Hz", path.display())]
    RateMismatch {
        /// The file.
        path: PathBuf,
        /// The rate given.
        given: f32,
        /// The file's rate.
        file: f32,
    },
    /// The manifest is malformed.
    #[error("cannot use the data-set manifest")]
    Manifest(#[from] ManifestError),
    /// Channels were selected by name in a file that does not name its channels.
    #[error(
        "{}: channels are selected by name only in files that name them (.mat, .tdms, \
         .uff/.unv); a CSV names its columns in its header, a WAV file its channels by order",
        path.display()
    )]
    NoChannelNames {
        /// The file.
        path: PathBuf,
    },
    /// The file extension is not one this loader knows.
    #[error(
        "{}: unsupported file type (expected .mat, .csv, .wav, .tdms, or .uff/.unv)",
        path.display()
    )]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
    },
    /// No sampling rate was given for a `.mat` file and no manifest lists it (a CSV
    /// file's missing rate is a [`CsvError::MissingSamplingRate`]).
    #[error(
        "{}: sampling rate unknown — pass it explicitly (e.g. --fs 12000) or keep the .mat \
         file beside a MANIFEST.tsv that lists it",
        path.display()
    )]
    MissingSamplingRate {
        /// The file.
        path: PathBuf,
    },
    /// A channel variable is a matrix, not a vector.
    #[error("{record}: variable `{variable}` has dimensions {dims:?}, expected a vector")]
    NotAVector {
        /// Recording name.
        record: String,
        /// Variable name.
        variable: String,
        /// Its dimensions.
        dims: Vec<usize>,
    },
    /// A variable named as a channel (`--channel DE=VAR`) is not in the file.
    #[error(
        "{}: no variable `{variable}` (for channel {channel}); numeric variables present: \
         [{present}]",
        path.display()
    )]
    MissingVariable {
        /// The file.
        path: PathBuf,
        /// The channel it was to fill.
        channel: String,
        /// The variable asked for.
        variable: String,
        /// The numeric variables the file holds (struct fields as `struct.field`).
        present: String,
    },
    /// The recording breaks what every consumer relies on.
    #[error(transparent)]
    Invalid(#[from] RecordingError),
}

/// Split a CWRU variable name `X<digits><suffix>` into number and suffix.
fn cwru_number(name: &str) -> Option<(u32, &str)> {
    let rest = name.strip_prefix('X')?;
    let digits = rest.len() - rest.trim_start_matches(|c: char| c.is_ascii_digit()).len();
    let number = rest[..digits].parse().ok()?;
    Some((number, &rest[digits..]))
}

/// The CWRU file number in a file stem (`105` → 105; `IR007_0` → none).
pub fn file_number_from_stem(path: &Path) -> Option<u32> {
    path.file_stem()?.to_str()?.parse().ok()
}

/// Pick the variable ending in `suffix` (`_DE_time`, `RPM`, …) for file `number`, or,
/// when `number` is `None`, the one whose number occurs most often in the file.
fn pick<'m>(
    mat: &'m MatFile,
    suffix: &str,
    number: Option<u32>,
    counts: &HashMap<u32, usize>,
) -> Option<&'m MatVariable> {
    let candidates = mat
        .variables
        .iter()
        .filter_map(|v| cwru_number(&v.name).map(|(n, s)| (v, n, s)))
        .filter(|(_, _, s)| *s == suffix);
    match number {
        Some(number) => candidates
            .filter(|(_, n, _)| *n == number)
            .map(|(v, _, _)| v)
            .next(),
        // max_by_key keeps the last maximum; reverse so the first in file order wins ties.
        None => candidates
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .max_by_key(|(_, n, _)| counts.get(n).copied().unwrap_or(0))
            .map(|(v, _, _)| v),
    }
}

/// Convert a CWRU vector variable to `f32` samples, rejecting non-finite values.
fn channel_samples(record: &str, channel: &str, v: &MatVariable) -> Result<Vec<f32>, DataError> {
    if !v.is_vector() {
        return Err(DataError::NotAVector {
            record: record.to_string(),
            variable: v.name.clone(),
            dims: v.dims.clone(),
        });
    }
    v.data
        .iter()
        .enumerate()
        .map(|(index, &x)| {
            let y = x as f32;
            if y.is_finite() {
                Ok(y)
            } else {
                Err(RecordingError::NonFiniteSample {
                    record: record.to_string(),
                    channel: channel.to_string(),
                    index,
                    value: x,
                }
                .into())
            }
        })
        .collect()
}

/// Build a [`Recording`] from a parsed CWRU MAT file.
///
/// `file_number` selects the variables (`X<nnn>_…`, zero-padded to 3 digits); see the
/// module docs for the fallback when it matches nothing. `rpm` is used only when the
/// file has no matching `RPM` variable.
pub fn recording_from_cwru_mat(
    mat: &MatFile,
    name: &str,
    file_number: Option<u32>,
    fs_hz: f32,
    rpm: Option<f32>,
) -> Result<Recording, DataError> {
    check_positive("fs_hz", fs_hz)?;
    if let Some(r) = rpm {
        check_positive("rpm", r)?;
    }
    let mut counts: HashMap<u32, usize> = HashMap::new();
    for v in &mat.variables {
        if let Some((n, suffix)) = cwru_number(&v.name) {
            let known =
                suffix == "RPM" || CWRU_CHANNELS.iter().any(|c| suffix == format!("_{c}_time"));
            if known {
                *counts.entry(n).or_default() += 1;
            }
        }
    }
    let by_number = file_number.filter(|n| {
        CWRU_CHANNELS
            .iter()
            .any(|c| pick(mat, &format!("_{c}_time"), Some(*n), &counts).is_some())
    });
    let mut channels = Vec::new();
    for c in CWRU_CHANNELS {
        if let Some(v) = pick(mat, &format!("_{c}_time"), by_number, &counts) {
            channels.push(Channel {
                name: c.to_string(),
                samples: channel_samples(name, c, v)?,
            });
        }
    }
    if channels.is_empty() {
        return Err(RecordingError::NoChannels {
            record: name.to_string(),
            present: numeric_names(mat),
        }
        .into());
    }
    let rpm_var = pick(mat, "RPM", by_number, &counts);
    let file_rpm = rpm_var
        .and_then(|v| v.data.first().copied())
        .map(|x| x as f32)
        .filter(|x| x.is_finite() && *x > 0.0);
    if let (Some(v), None) = (rpm_var, file_rpm) {
        // Said, not dropped in silence: the caller's --rpm (or its absence) decides.
        eprintln!(
            "{name}: variable {} holds {:?}, not a shaft speed: ignored",
            v.name,
            v.data.first()
        );
    }
    let recording = Recording {
        name: name.to_string(),
        fs_hz,
        rpm: file_rpm.or(rpm),
        channels,
    };
    recording.validate()?;
    Ok(recording)
}

/// Load a CWRU `.mat` file sampled at `fs_hz`. The file number is `file_number` or,
/// when `None`, the file stem if it is a number.
pub fn load_cwru_mat(
    path: &Path,
    file_number: Option<u32>,
    fs_hz: f32,
    rpm: Option<f32>,
) -> Result<Recording, DataError> {
    let bytes = read_file(path)?;
    cwru_mat_from_bytes(path, &bytes, file_number, fs_hz, rpm)
}

/// [`load_cwru_mat`] on the file's bytes, read already (`path` names the record and
/// its errors).
pub(crate) fn cwru_mat_from_bytes(
    path: &Path,
    bytes: &[u8],
    file_number: Option<u32>,
    fs_hz: f32,
    rpm: Option<f32>,
) -> Result<Recording, DataError> {
    let mat = read_mat(bytes).map_err(|source| DataError::Mat {
        path: path.to_path_buf(),
        source,
    })?;
    let number = file_number.or_else(|| file_number_from_stem(path));
    recording_from_cwru_mat(&mat, &stem_name(path), number, fs_hz, rpm)
}

/// The names of a file's numeric variables, comma-separated (for the errors that say
/// what a file holds).
fn numeric_names(mat: &MatFile) -> String {
    mat.variables
        .iter()
        .map(|v| v.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The bytes of the file at `path`.
fn read_file(path: &Path) -> Result<Vec<u8>, DataError> {
    std::fs::read(path).map_err(|source| DataError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// A `.mat` file's rate: the one given, else its data set's `MANIFEST.tsv` entry.
fn mat_rate(path: &Path, fs_hz: Option<f32>) -> Result<f32, DataError> {
    match fs_hz {
        Some(fs) => Ok(fs),
        None => manifest_fs_hz(path)?.ok_or_else(|| DataError::MissingSamplingRate {
            path: path.to_path_buf(),
        }),
    }
}

/// Load a `.mat` file whatever its layout: each `(channel, variable)` pair names the
/// numeric vector (a top-level variable, or a struct's field as `struct.field`) that
/// becomes that channel, e.g. `("DE", "bearing.gs")` for an MFPT file or
/// `("DE", "V0")` for a DAQ export. The rate is `fs_hz` (else the data set's
/// `MANIFEST.tsv`, as for CWRU files), the speed `rpm` (else unknown). A variable the
/// file lacks is an error that lists the ones it has.
pub fn load_mat_channels(
    path: &Path,
    channels: &[(String, String)],
    fs_hz: Option<f32>,
    rpm: Option<f32>,
) -> Result<Recording, DataError> {
    let fs_hz = mat_rate(path, fs_hz)?;
    check_positive("fs_hz", fs_hz)?;
    if let Some(r) = rpm {
        check_positive("rpm", r)?;
    }
    let bytes = read_file(path)?;
    let mat = read_mat(&bytes).map_err(|source| DataError::Mat {
        path: path.to_path_buf(),
        source,
    })?;
    let name = stem_name(path);
    let mut out = Vec::with_capacity(channels.len());
    for (channel, variable) in channels {
        let v = mat
            .variable(variable)
            .ok_or_else(|| DataError::MissingVariable {
                path: path.to_path_buf(),
                channel: channel.clone(),
                variable: variable.clone(),
                present: numeric_names(&mat),
            })?;
        out.push(Channel {
            name: channel.clone(),
            samples: channel_samples(&name, channel, v)?,
        });
    }
    let recording = Recording {
        name,
        fs_hz,
        rpm,
        channels: out,
    };
    recording.validate()?;
    Ok(recording)
}

/// Load a CSV recording; sampling rate and speed from the caller or the file's
/// declaration ([`parse_csv`]).
pub fn load_csv(path: &Path, fs_hz: Option<f32>, rpm: Option<f32>) -> Result<Recording, DataError> {
    let text = std::fs::read_to_string(path).map_err(|source| DataError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let recording =
        parse_csv(&text, &stem_name(path), fs_hz, rpm).map_err(|source| DataError::Csv {
            path: path.to_path_buf(),
            source,
        })?;
    recording.validate()?;
    Ok(recording)
}

/// The sampling rate a `MANIFEST.tsv` in the file's directory or the one above lists
/// for `path`, if any.
pub fn manifest_fs_hz(path: &Path) -> Result<Option<f32>, DataError> {
    let target = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    for dir in path.ancestors().skip(1).take(2) {
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        let manifest = dir.join(MANIFEST_FILE);
        if !manifest.is_file() {
            continue;
        }
        let text = std::fs::read_to_string(&manifest).map_err(|source| DataError::Io {
            path: manifest.clone(),
            source,
        })?;
        let entries = parse_manifest(&text, dir)?;
        let found = entries
            .iter()
            .find(|e| e.path.canonicalize().unwrap_or_else(|_| e.path.clone()) == target);
        if let Some(entry) = found {
            return Ok(Some(entry.fs_hz));
        }
    }
    Ok(None)
}

/// Load a WAV recording ([`crate::wav`]); a rate given must agree with the header's.
pub fn load_wav(path: &Path, fs_hz: Option<f32>, rpm: Option<f32>) -> Result<Recording, DataError> {
    let bytes = read_file(path)?;
    let rec =
        crate::wav::parse_wav(&bytes, &crate::wav::record_name(path), rpm).map_err(|source| {
            DataError::Wav {
                path: path.to_path_buf(),
                source,
            }
        })?;
    if let Some(given) = fs_hz {
        if (given - rec.fs_hz).abs() > 1e-3 * rec.fs_hz {
            return Err(DataError::RateMismatch {
                path: path.to_path_buf(),
                given,
                file: rec.fs_hz,
            });
        }
    }
    Ok(rec)
}

/// Load a TDMS or universal file ([`crate::tdms`], [`crate::uff`]): channels, units
/// and rate from the file, through [`crate::channels::assemble`] with `selection`
/// (`(channel, the file's name)` pairs; empty: every channel).
pub fn load_described(
    path: &Path,
    selection: &[(String, String)],
    fs_hz: Option<f32>,
    rpm: Option<f32>,
) -> Result<Recording, DataError> {
    let bytes = read_file(path)?;
    let p = || path.to_path_buf();
    let channels = if has_extension(path, &["tdms"]) {
        crate::tdms::parse_tdms(&bytes).map_err(|source| DataError::Tdms { path: p(), source })?
    } else {
        crate::uff::parse_uff(&bytes).map_err(|source| DataError::Uff { path: p(), source })?
    };
    let rec = crate::channels::assemble(&stem_name(path), channels, selection, fs_hz, rpm)
        .map_err(|source| DataError::Channels { path: p(), source })?;
    rec.validate()?;
    Ok(rec)
}

/// Whether `path` ends in one of `exts` (lower case), in any case.
fn has_extension(path: &Path, exts: &[&str]) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| exts.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// Whether the file's format names its channels, so that a selection
/// (`--var CHANNEL=NAME`) can pick them: `.mat` (variables), `.tdms`, `.uff`/`.unv`.
pub fn names_its_channels(path: &Path) -> bool {
    has_extension(path, &["mat", "tdms", "uff", "unv"])
}

/// Load a recording, choosing the reader by extension; `selection` picks and names
/// channels of a file that names its own ([`names_its_channels`]; empty: the file's
/// own layout).
///
/// - `.mat`: CWRU layout, or the variables `selection` names; `fs_hz` from the
///   caller, else from a `MANIFEST.tsv` beside the file (or one directory up) that
///   lists it; rpm from the file, else the caller.
/// - `.csv`: `fs_hz` and rpm from the caller, else from the file's declaration
///   (`# fs_hz=12000 rpm=1797` before the header); both given must agree.
/// - `.wav`: `fs_hz` from the header (a rate given must agree), rpm from the caller.
/// - `.tdms`, `.uff`/`.unv`: channels, units and rate from the file (a rate given
///   must agree), rpm from the caller.
pub fn load_recording_with(
    path: &Path,
    selection: &[(String, String)],
    fs_hz: Option<f32>,
    rpm: Option<f32>,
) -> Result<Recording, DataError> {
    if !selection.is_empty() && !names_its_channels(path) {
        return Err(DataError::NoChannelNames {
            path: path.to_path_buf(),
        });
    }
    if has_extension(path, &["mat"]) {
        if !selection.is_empty() {
            return load_mat_channels(path, selection, fs_hz, rpm);
        }
        let fs_hz = mat_rate(path, fs_hz)?;
        return load_cwru_mat(path, None, fs_hz, rpm);
    }
    if has_extension(path, &["csv"]) {
        return load_csv(path, fs_hz, rpm);
    }
    if has_extension(path, &["wav"]) {
        return load_wav(path, fs_hz, rpm);
    }
    if has_extension(path, &["tdms", "uff", "unv"]) {
        return load_described(path, selection, fs_hz, rpm);
    }
    Err(DataError::UnsupportedFormat {
        path: path.to_path_buf(),
    })
}

/// Load a recording in its file's own layout ([`load_recording_with`], no selection).
pub fn load_recording(
    path: &Path,
    fs_hz: Option<f32>,
    rpm: Option<f32>,
) -> Result<Recording, DataError> {
    load_recording_with(path, &[], fs_hz, rpm)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::mat::writer::double_vectors;
    use crate::test_support::{cwru_dir, scratch_dir};

    /// Named variables of any layout become the channels; a missing one is an error
    /// that lists what the file holds, a rate is required.
    #[test]
    fn named_variables_become_channels() {
        let dir = scratch_dir("named-vars");
        let path = dir.join("daq.mat");
        let x: Vec<f64> = (0..64).map(|i| f64::from(i) * 0.01).collect();
        let y: Vec<f64> = x.iter().map(|v| -v).collect();
        std::fs::write(&path, double_vectors(&[("V0", &x), ("acc_fe", &y)])).expect("write");
        let pairs = |p: &[(&str, &str)]| -> Vec<(String, String)> {
            p.iter()
                .map(|(c, v)| (c.to_string(), v.to_string()))
                .collect()
        };
        let rec = load_mat_channels(
            &path,
            &pairs(&[("DE", "V0"), ("FE", "acc_fe")]),
            Some(20_000.0),
            Some(900.0),
        )
        .expect("named channels");
        assert_eq!(rec.channels.len(), 2);
        assert_eq!(rec.channel("FE").expect("FE").samples[3], -0.03);
        assert_eq!((rec.fs_hz, rec.rpm, rec.len()), (20_000.0, Some(900.0), 64));
        let err = load_mat_channels(&path, &pairs(&[("DE", "nope")]), Some(20_000.0), None)
            .expect_err("missing variable");
        assert!(
            matches!(&err, DataError::MissingVariable { variable, .. } if variable == "nope"),
            "{err}"
        );
        assert!(err.to_string().contains("V0, acc_fe"), "{err}");
        assert!(matches!(
            load_mat_channels(&path, &pairs(&[("DE", "V0")]), None, None),
            Err(DataError::MissingSamplingRate { .. })
        ));
        assert!(matches!(
            load_mat_channels(&path, &pairs(&[("DE", "V0")]), Some(-1.0), None),
            Err(DataError::Invalid(RecordingError::InvalidParameter {
                what: "fs_hz",
                ..
            }))
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn mat(vars: &[(&str, &[f64])]) -> MatFile {
        read_mat(&double_vectors(vars)).expect("test file")
    }

    #[test]
    fn picks_variables_by_file_number() {
        // 99.mat carries 98's variables too; the file number must win.
        let m = mat(&[
            ("X098_DE_time", &[9.0, 9.0]),
            ("X098_FE_time", &[9.0, 9.0]),
            ("X099_DE_time", &[1.0, 2.0, 3.0]),
            ("X099_FE_time", &[4.0, 5.0, 6.0]),
            ("X098RPM", &[1772.0]),
            ("X099RPM", &[1750.0]),
            ("ans", &[0.0]),
        ]);
        let r = recording_from_cwru_mat(&m, "99", Some(99), 12_000.0, Some(1.0)).expect("valid");
        assert_eq!(r.channels.len(), 2);
        assert_eq!(r.channel("DE").expect("DE").samples, vec![1.0, 2.0, 3.0]);
        assert_eq!(r.channel("FE").expect("FE").samples, vec![4.0, 5.0, 6.0]);
        assert_eq!(r.rpm, Some(1750.0), "rpm comes from the file");
        assert_eq!(r.len(), 3);
    }

    #[test]
    fn falls_back_to_the_most_frequent_number() {
        // Renamed file: no number; X210 has three variables, X209 one.
        let m = mat(&[
            ("X209_DE_time", &[7.0]),
            ("X210_DE_time", &[1.0, 2.0]),
            ("X210_FE_time", &[3.0, 4.0]),
            ("X210_BA_time", &[5.0, 6.0]),
        ]);
        let r =
            recording_from_cwru_mat(&m, "IR021_1", None, 12_000.0, Some(1774.0)).expect("valid");
        let names: Vec<_> = r.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["DE", "FE", "BA"]);
        assert_eq!(r.channels[0].samples, vec![1.0, 2.0]);
        assert_eq!(r.rpm, Some(1774.0), "no RPM variable: the caller's value");
        // A file number that matches nothing also falls back.
        let r = recording_from_cwru_mat(&m, "5", Some(5), 12_000.0, None).expect("valid");
        assert_eq!(r.channels[0].samples, vec![1.0, 2.0]);
    }

    #[test]
    fn rejects_bad_content() {
        let m = mat(&[
            ("X001_DE_time", &[1.0, f64::NAN]),
            ("X001_FE_time", &[1.0, 2.0]),
        ]);
        let err = recording_from_cwru_mat(&m, "1", Some(1), 12_000.0, None).expect_err("NaN");
        assert!(
            matches!(&err, DataError::Invalid(RecordingError::NonFiniteSample { channel, index: 1, .. }) if channel == "DE"),
            "{err}"
        );
        let m = mat(&[("X001_DE_time", &[1.0, 1e300])]);
        assert!(matches!(
            recording_from_cwru_mat(&m, "1", Some(1), 12_000.0, None),
            Err(DataError::Invalid(RecordingError::NonFiniteSample {
                index: 1,
                ..
            }))
        ));
        let m = mat(&[("X001_DE_time", &[1.0, 2.0]), ("X001_FE_time", &[1.0])]);
        assert!(matches!(
            recording_from_cwru_mat(&m, "1", Some(1), 12_000.0, None),
            Err(DataError::Invalid(
                RecordingError::UnequalChannelLengths { .. }
            ))
        ));
        let m = mat(&[("signal", &[1.0])]);
        let err =
            recording_from_cwru_mat(&m, "1", Some(1), 12_000.0, None).expect_err("no channels");
        assert!(err.to_string().contains("signal"), "{err}");
        let m = mat(&[("X001_DE_time", &[1.0])]);
        assert!(matches!(
            recording_from_cwru_mat(&m, "1", Some(1), 0.0, None),
            Err(DataError::Invalid(RecordingError::InvalidParameter {
                what: "fs_hz",
                ..
            }))
        ));
    }

    #[test]
    fn load_recording_dispatches_and_needs_a_rate() {
        let dir = scratch_dir("record");
        std::fs::write(
            dir.join("7.mat"),
            double_vectors(&[("X007_DE_time", &[0.5, 0.25])]),
        )
        .expect("write");
        std::fs::write(dir.join("p.csv"), "DE\n1\n2\n").expect("write");
        std::fs::write(dir.join("p.wav"), "RIFF").expect("write");
        let err = load_recording(&dir.join("7.mat"), None, None).expect_err("no rate");
        assert!(
            matches!(err, DataError::MissingSamplingRate { .. }),
            "{err}"
        );
        let r = load_recording(&dir.join("7.mat"), Some(12_000.0), Some(1797.0)).expect("mat");
        assert_eq!(r.name, "7");
        assert_eq!(r.channels[0].samples, vec![0.5, 0.25]);
        assert!(matches!(
            load_recording(&dir.join("p.csv"), None, None),
            Err(DataError::Csv {
                source: CsvError::MissingSamplingRate,
                ..
            })
        ));
        let r = load_recording(&dir.join("p.csv"), Some(1000.0), None).expect("csv");
        assert_eq!(r.channels[0].samples, vec![1.0, 2.0]);
        assert!(matches!(
            load_recording(&dir.join("p.flac"), Some(1.0), None),
            Err(DataError::UnsupportedFormat { .. })
        ));
        // A WAV file cut after its "RIFF" is malformed, named (the reader is tested in
        // `wav`).
        assert!(matches!(
            load_recording(&dir.join("p.wav"), Some(1.0), None),
            Err(DataError::Wav { .. })
        ));
        // A manifest beside the file supplies the rate.
        std::fs::write(
            dir.join(MANIFEST_FILE),
            "file\tcwru_file_no\tcwru_label\tfault_type\tfault_size_in\tload_hp\trpm_recorded\tfs_hz\n\
             7.mat\t7\tX\tnormal\t0\t0\t1797\t48000\n",
        )
        .expect("write");
        let r = load_recording(&dir.join("7.mat"), None, None).expect("rate from manifest");
        assert_eq!(r.fs_hz, 48_000.0);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn loads_every_cwru_record() {
        let Some(dir) = cwru_dir() else { return };
        let entries = crate::manifest::read_manifest(&dir).expect("manifest");
        for e in &entries {
            let r =
                load_cwru_mat(&e.path, Some(e.file_number), e.fs_hz, None).expect("record loads");
            let expected_channels = if e.fault_type == crate::manifest::FaultType::Normal {
                2
            } else {
                3
            };
            assert_eq!(r.channels.len(), expected_channels, "{}", e.label);
            if let Some(n) = e.samples_per_channel {
                assert_eq!(r.len(), n, "{}", e.label);
            }
            let rpm = r.rpm.expect("CWRU files carry RPM");
            let listed = e.rpm_recorded.expect("manifest lists rpm");
            assert!(
                (rpm - listed).abs() < 1.0,
                "{}: rpm {rpm} vs {listed}",
                e.label
            );
        }
        // Loading through the extension dispatcher finds the rate in the manifest.
        let r = load_recording(&dir.join("normal/97.mat"), None, None).expect("97.mat");
        assert_eq!(r.fs_hz, 48_000.0);
    }
}
