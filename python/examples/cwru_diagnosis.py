#!/usr/bin/env python3
"""One CWRU diagnosis and one closed-loop report from Python (the README's figures).

    pip install ./python            # builds the Rust extension with maturin
    python python/examples/cwru_diagnosis.py [RECORD]

RECORD defaults to the repository's fixture, the first second of CWRU record 105
(inner race, 0.007 in, 0 HP, 1797 rpm) at 12 kHz; any file the command line reads
works (e.g. ../shared/data/cwru/12k_DE/105.mat with --fs from its manifest).
"""
import pathlib
import sys

import numpy as np

import pumptwin

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main(path: pathlib.Path) -> None:
    rec = pumptwin.read(path, fs=12_000, rpm=1797)
    channels = rec["channels"]
    print(f"record: {rec['name']}, {rec['fs_hz']:.0f} Hz, channels {', '.join(channels)}")

    report = pumptwin.predict(channels, fs=rec["fs_hz"], rpm=1797, bearing="cwru-6205-de")
    d = report["diagnosis"]
    print(f"network majority class: {report['majority_class']} "
          f"({report['class_counts'][report['majority_class']]} of {len(report['windows'])} windows)")
    print(f"diagnosis: {d['fault_type']}, confidence {d['confidence']:.2f}, decided by {d['decided_by']}")

    loop = pumptwin.twin_loop(channels["DE"], fs=rec["fs_hz"], rpm=1797, bearing="cwru-6205-de")
    r, s = loop["report"], loop["spectra"]
    print(f"closed loop: fault hypothesis {r['fault']}, PSD error "
          f"{r['error_initial']['psd_log_rmse_db']:.2f} dB after the first fit, "
          f"{r['error_final']['psd_log_rmse_db']:.2f} dB at the end")
    print("effects added: " + (", ".join(st["effect"] for st in r["steps"]) or "none"))
    # The spectra are numpy arrays: e.g. where the final model misses the measurement most.
    worst = int(np.argmax(np.abs(s["psd_measured_db"] - s["psd_final_db"])))
    print(f"largest PSD misfit at {s['psd_freq_hz'][worst]:.0f} Hz")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "tests/data/cwru105_1s.csv")
