//! `pumptwin._native`: the Rust side of the Python package. Thin: every function
//! calls the library the command line calls (`pumptwin::predict::predict`,
//! `pumptwin::commands::twin_loop`, `pumptwin_data::record::load_recording_with`)
//! and hands back JSON text and little-endian `float32` buffers, which the Python
//! wrapper (`pumptwin/__init__.py`) turns into dicts and numpy arrays. An error
//! of the library is a `ValueError` carrying its whole chain of causes.

/// The Python module.
#[pyo3::pymodule]
mod _native {
    use std::path::PathBuf;

    use pumptwin::commands::{loop_rate, twin_loop as run_loop, RecordArgs};
    use pumptwin::predict::{int8_model, load_model, predict as run_predict};
    use pumptwin_data::record::{load_recording_with, Channel, Recording};
    use pyo3::exceptions::PyValueError;
    use pyo3::prelude::*;
    use pyo3::types::PyBytes;

    /// The shipped int8 model (`models/dsstgat-cwru-tb.ptm`), built in.
    const SHIPPED_MODEL: &[u8] = include_bytes!("../../models/dsstgat-cwru-tb.ptm");
    /// Its name in reports.
    const SHIPPED_NAME: &str = "dsstgat-cwru-tb.ptm (built in)";

    fn value_error(e: anyhow::Error) -> PyErr {
        PyValueError::new_err(format!("{e:#}"))
    }

    /// Little-endian f32 bytes of samples.
    fn to_bytes<'py>(py: Python<'py>, samples: &[f32]) -> Bound<'py, PyBytes> {
        let raw: Vec<u8> = samples.iter().flat_map(|v| v.to_le_bytes()).collect();
        PyBytes::new(py, &raw)
    }

    /// A recording from channel names and their samples laid end to end (f32 LE).
    fn recording(names: Vec<String>, data: &[u8], fs: f32, rpm: f32) -> PyResult<Recording> {
        let n_ch = names.len();
        if n_ch == 0 || data.is_empty() || data.len() % (4 * n_ch) != 0 {
            return Err(PyValueError::new_err(format!(
                "{} bytes are not {n_ch} channels of float32 samples",
                data.len()
            )));
        }
        let n = data.len() / 4 / n_ch;
        let values: Vec<f32> = data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let channels = names
            .into_iter()
            .zip(values.chunks_exact(n.max(1)))
            .map(|(name, s)| Channel {
                name,
                samples: s.to_vec(),
            })
            .collect();
        Ok(Recording {
            name: "signal".into(),
            fs_hz: fs,
            rpm: Some(rpm),
            channels,
        })
    }

    /// What a user knows of an in-memory record (no file behind it).
    fn record_args(fs: f32, rpm: f32, bearing: &str) -> RecordArgs {
        RecordArgs {
            input: PathBuf::from("<python>"),
            fs: Some(fs),
            rpm: Some(rpm),
            bearing: bearing.to_string(),
            var: Vec::new(),
        }
    }

    /// Read a recording file (.mat, .csv, .wav, .tdms, .uff): its name, rate, speed,
    /// and channels as `(name, float32 bytes)`.
    #[pyfunction]
    #[pyo3(signature = (path, fs=None, rpm=None, var=Vec::new()))]
    #[allow(clippy::type_complexity)]
    fn read<'py>(
        py: Python<'py>,
        path: PathBuf,
        fs: Option<f32>,
        rpm: Option<f32>,
        var: Vec<(String, String)>,
    ) -> PyResult<(String, f32, Option<f32>, Vec<(String, Bound<'py, PyBytes>)>)> {
        let rec = load_recording_with(&path, &var, fs, rpm)
            .map_err(|e| value_error(anyhow::Error::new(e)))?;
        let channels = rec
            .channels
            .iter()
            .map(|c| (c.name.clone(), to_bytes(py, &c.samples)))
            .collect();
        Ok((rec.name, rec.fs_hz, rec.rpm, channels))
    }

    /// `pumptwin predict` on channels `names` (samples laid end to end in `data`,
    /// float32 LE) at `fs` Hz and `rpm`: the report as JSON text. `model`: a model
    /// file path, or `None` for the shipped int8 model.
    #[pyfunction]
    #[pyo3(signature = (names, data, fs, rpm, bearing, model=None))]
    fn predict(
        py: Python<'_>,
        names: Vec<String>,
        data: &[u8],
        fs: f32,
        rpm: f32,
        bearing: &str,
        model: Option<PathBuf>,
    ) -> PyResult<String> {
        let raw = recording(names, data, fs, rpm)?;
        let args = record_args(fs, rpm, bearing);
        py.detach(|| {
            let loaded = args.prepare(raw)?;
            let (net, name) = match &model {
                Some(p) => (load_model(p)?, p.display().to_string()),
                None => (
                    int8_model(SHIPPED_MODEL, SHIPPED_NAME)?,
                    SHIPPED_NAME.into(),
                ),
            };
            let report = run_predict(&loaded, "<python>", &net, &name)?;
            Ok(serde_json::to_string(&report)?)
        })
        .map_err(value_error)
    }

    /// `pumptwin twin loop` on one channel (float32 LE) at `fs` Hz and `rpm`: the
    /// report as JSON text and the spectra as `(name, float32 bytes)`: PSD frequency,
    /// measured, first fit and final (dB re the measured median), envelope frequency,
    /// measured, first fit and final (linear).
    #[pyfunction]
    #[allow(clippy::type_complexity)]
    fn twin_loop<'py>(
        py: Python<'py>,
        data: &[u8],
        fs: f32,
        rpm: f32,
        bearing: &str,
    ) -> PyResult<(String, Vec<(String, Bound<'py, PyBytes>)>)> {
        use pumptwin_twin::closed_loop::{envelope_pairs, psd_pairs};
        let raw = recording(vec!["DE".into()], data, fs, rpm)?;
        let args = record_args(fs, rpm, bearing);
        let (json, series) = py
            .detach(|| {
                let loaded = args.prepare_at(raw, loop_rate)?;
                let (report, art, _) = run_loop(&loaded, "<python>", None, 1.0)?;
                let psd_i = psd_pairs(&art, &art.initial);
                let psd_f = psd_pairs(&art, &art.final_);
                let env_i = envelope_pairs(&art, &art.initial);
                let env_f = envelope_pairs(&art, &art.final_);
                let col = |v: &[(f32, f32, f32)], k: usize| -> Vec<f32> {
                    v.iter().map(|t| [t.0, t.1, t.2][k]).collect()
                };
                let series: Vec<(&str, Vec<f32>)> = vec![
                    ("psd_freq_hz", col(&psd_i, 0)),
                    ("psd_measured_db", col(&psd_i, 1)),
                    ("psd_initial_db", col(&psd_i, 2)),
                    ("psd_final_db", col(&psd_f, 2)),
                    ("env_freq_hz", col(&env_i, 0)),
                    ("env_measured", col(&env_i, 1)),
                    ("env_initial", col(&env_i, 2)),
                    ("env_final", col(&env_f, 2)),
                ];
                anyhow::Ok((serde_json::to_string(&report)?, series))
            })
            .map_err(value_error)?;
        let spectra = series
            .into_iter()
            .map(|(k, v)| (k.to_string(), to_bytes(py, &v)))
            .collect();
        Ok((json, spectra))
    }
}
