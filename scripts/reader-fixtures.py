#!/usr/bin/env python3
"""Write the CSV fixture of CWRU record 105 as NI TDMS and universal file format 58
files with other tools than ours (npTDMS and pyuff from PyPI), for the readers'
same-diagnosis tests (tests/data/README.md says what each file is).

    python3 -m venv /tmp/fixtures && /tmp/fixtures/bin/pip install numpy npTDMS==1.13.0 pyuff==2.5.8
    /tmp/fixtures/bin/python scripts/reader-fixtures.py

Re-running it rewrites the same files (no time stamp is written).
"""
import pathlib

import numpy as np
import nptdms
import pyuff

ROOT = pathlib.Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
FS_HZ = 12_000.0


def fixture():
    lines = (DATA / "cwru105_1s.csv").read_text().splitlines()
    body = [l for l in lines if l and not l.startswith("#")]
    names = body[0].split(",")
    values = np.array([[float(v) for v in l.split(",")] for l in body[1:]])
    return names, values


def write_tdms(names, values):
    # Two segments of 6 000 samples each, float32, in a group "Vibration"; the rate as
    # LabVIEW's waveform attribute wf_increment, the unit as unit_string. Channels
    # named as a DAQ names them ("accel DE"): the reader maps the token to DE.
    path = DATA / "cwru105_1s.tdms"
    half = values.shape[0] // 2
    with nptdms.TdmsWriter(str(path)) as w:
        for part in (values[:half], values[half:]):
            chans = [
                nptdms.ChannelObject(
                    "Vibration",
                    f"accel {name}",
                    part[:, k].astype(np.float32),
                    properties={"wf_increment": 1.0 / FS_HZ, "unit_string": "g"},
                )
                for k, name in enumerate(names)
            ]
            w.write_segment([nptdms.RootObject({"name": "CWRU 105"}), nptdms.GroupObject("Vibration")] + chans)


def write_uff(names, values, binary):
    # One data set 58 per channel (function type 1, time response), time abscissa
    # evenly spaced at 1/12 kHz, ordinate acceleration in g: ASCII in single
    # precision (6E13.5), binary (58b) in double.
    suffix = "_58b" if binary else ""
    path = DATA / f"cwru105_1s{suffix}.uff"
    path.write_bytes(b"")
    uff = pyuff.UFF(str(path))
    t = np.arange(values.shape[0]) / FS_HZ
    sets = []
    for k, name in enumerate(names):
        sets.append(
            pyuff.prepare_58(
                binary=1 if binary else 0,
                id1=name,
                id2="CWRU record 105, IR007, 0 HP",
                id3="NONE",
                id4="NONE",
                id5="NONE",
                func_type=1,
                rsp_node=k + 1,
                rsp_dir=3,
                ref_node=0,
                ref_dir=0,
                abscissa_spacing=1,
                abscissa_spec_data_type=17,
                abscissa_axis_units_lab="s",
                ordinate_spec_data_type=12,
                ordinate_axis_units_lab="g",
                orddenom_spec_data_type=13,
                ord_data_type=4 if binary else 2,
                data=values[:, k],
                x=t,
            )
        )
    # Appended to an empty file: pyuff 2.5.8's "overwrite" mode reopens the file for the
    # binary data of the first set and so truncates that set's own header.
    path.write_bytes(b"")
    uff.write_sets(sets, mode="add", force_double=binary)


def main():
    names, values = fixture()
    assert names == ["DE", "FE", "BA"], names
    write_tdms(names, values)
    write_uff(names, values, binary=False)
    write_uff(names, values, binary=True)
    for p in sorted(DATA.glob("cwru105_1s*")):
        print(f"{p.name}: {p.stat().st_size} bytes")


if __name__ == "__main__":
    main()
