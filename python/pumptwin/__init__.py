"""pumptwin from Python: physics-informed diagnosis of rolling bearings.

The functions call the same Rust code as the ``pumptwin`` command line and return
plain Python: dicts (the command line's JSON reports) and numpy arrays.

    import numpy as np, pumptwin
    rec = pumptwin.read("tests/data/cwru105_1s.csv", fs=12000, rpm=1797)
    report = pumptwin.predict(rec["channels"], fs=rec["fs_hz"], rpm=1797)
    report["diagnosis"]["fault_type"]            # 'inner_race'
    loop = pumptwin.twin_loop(rec["channels"]["DE"], fs=rec["fs_hz"], rpm=1797)
    loop["report"]["fault"], loop["spectra"]["psd_final_db"]

Every field of the reports is explained in ``docs/output.md`` (predict) and
``docs/closed-loop.md`` (the loop) of the repository. A bad input raises
``ValueError`` with the library's message and its causes.
"""

import json
from typing import Dict, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native

__all__ = ["read", "predict", "twin_loop", "BEARINGS"]

#: Bearings known by name; any other is ``"n,d,D,angle_deg"`` (elements, ball
#: diameter, pitch diameter, contact angle; d and D in the same unit).
BEARINGS = ("cwru-6205-de", "cwru-6203-fe")

Signal = Union[np.ndarray, Sequence[float]]


def _f32_bytes(x: Signal) -> bytes:
    a = np.asarray(x, dtype="<f4")
    if a.ndim != 1:
        raise ValueError(f"a channel must be one-dimensional, got shape {a.shape}")
    return np.ascontiguousarray(a).tobytes()


def _array(b: bytes) -> np.ndarray:
    return np.frombuffer(b, dtype="<f4").copy()


def read(path, fs: Optional[float] = None, rpm: Optional[float] = None,
         var: Optional[Mapping[str, str]] = None) -> dict:
    """Read a recording (.mat, .csv, .wav, .tdms, .uff/.unv) as the command line does.

    ``var`` maps channels to the file's own names (``{"DE": "acc_drive_end"}``), as
    ``--var DE=acc_drive_end``. Returns ``{"name", "fs_hz", "rpm", "channels"}``
    with ``channels`` a dict of float32 numpy arrays: the sensor channels DE, FE, BA
    in g where the file gives their unit (else as stored, taken as g), any other
    channel as stored.
    """
    pairs = list((var or {}).items())
    name, fs_hz, file_rpm, channels = _native.read(str(path), fs, rpm, pairs)
    return {
        "name": name,
        "fs_hz": fs_hz,
        "rpm": file_rpm,
        "channels": {k: _array(v) for k, v in channels},
    }


def predict(signal: Union[Signal, Mapping[str, Signal]], fs: float, rpm: float,
            bearing: str = "cwru-6205-de", model: Optional[str] = None) -> dict:
    """Diagnose a record: ``pumptwin predict``'s JSON report as a dict.

    ``signal`` is the drive-end channel (1-D, in g) or a dict of channels named
    ``DE``, ``FE``, ``BA``; ``fs`` its rate in Hz (any: resampled to the model's
    12 kHz), ``rpm`` the shaft speed, ``bearing`` a name of ``BEARINGS`` or
    ``"n,d,D,angle_deg"``. ``model``: a model file (``.ptm``) or burn ``model.bpk``;
    ``None`` runs the shipped int8 DS-STGAT. The report's ``diagnosis`` holds the
    fault type, its confidence, severity and who decided it.
    """
    channels: Dict[str, Signal] = (
        dict(signal) if isinstance(signal, Mapping) else {"DE": signal}
    )
    names = list(channels)
    data = [_f32_bytes(channels[n]) for n in names]
    if len({len(d) for d in data}) > 1:
        raise ValueError("channels of different lengths: not one simultaneous recording")
    text = _native.predict(names, b"".join(data), float(fs), float(rpm), bearing,
                           None if model is None else str(model))
    return json.loads(text)


def twin_loop(signal: Signal, fs: float, rpm: float, bearing: str = "cwru-6205-de") -> dict:
    """The closed loop between the record and the bearing model (``pumptwin twin loop``).

    Returns ``{"report": dict, "spectra": dict of numpy arrays}``: the report the
    command writes as ``report.json`` (first fit, each effect added with its
    evidence, rejected candidates, errors before and after), and the spectra it
    plots: ``psd_freq_hz``, ``psd_measured_db``, ``psd_initial_db``,
    ``psd_final_db``, ``env_freq_hz``, ``env_measured``, ``env_initial``,
    ``env_final``.
    """
    text, spectra = _native.twin_loop(_f32_bytes(signal), float(fs), float(rpm), bearing)
    return {"report": json.loads(text), "spectra": {k: _array(v) for k, v in spectra}}
