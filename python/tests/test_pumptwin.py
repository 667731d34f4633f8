"""pytest for the Python package: the same answers as the command line, files written
by other tools (scipy), and a clear ValueError for bad input."""
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest
import scipy.io
import scipy.io.wavfile

import pumptwin

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"


@pytest.fixture(scope="module")
def fixture():
    return pumptwin.read(DATA / "cwru105_1s.csv", fs=12_000, rpm=1797)


def test_read_gives_the_fixture_as_numpy(fixture):
    assert fixture["fs_hz"] == 12_000
    assert list(fixture["channels"]) == ["DE", "FE", "BA"]
    de = fixture["channels"]["DE"]
    assert de.dtype == np.float32 and de.shape == (12_000,)
    first = DATA.joinpath("cwru105_1s.csv").read_text().splitlines()[3]
    assert de[0] == pytest.approx(float(first.split(",")[0]), abs=1e-6)


@pytest.mark.parametrize("name", ["cwru105_1s.tdms", "cwru105_1s.uff", "cwru105_1s_58b.uff"])
def test_every_format_reads_the_same_samples(fixture, name):
    rec = pumptwin.read(DATA / name)
    assert rec["fs_hz"] == 12_000, "the rate comes from the file"
    for ch, x in fixture["channels"].items():
        np.testing.assert_allclose(rec["channels"][ch], x, rtol=1e-5, atol=1e-6)


def test_files_written_by_scipy_read_the_same(fixture, tmp_path):
    x = np.stack([fixture["channels"][c] for c in ("DE", "FE", "BA")], axis=1)
    wav = tmp_path / "rec.wav"
    scipy.io.wavfile.write(wav, 12_000, x.astype(np.float32))
    rec = pumptwin.read(wav, rpm=1797)
    np.testing.assert_array_equal(rec["channels"]["FE"], fixture["channels"]["FE"])
    mat = tmp_path / "daq.mat"
    scipy.io.savemat(mat, {"acc_de": x[:, 0].astype(np.float64), "acc_fe": x[:, 1].astype(np.float64)})
    rec = pumptwin.read(mat, fs=12_000, rpm=1797, var={"DE": "acc_de", "FE": "acc_fe"})
    assert list(rec["channels"]) == ["DE", "FE"]
    np.testing.assert_allclose(rec["channels"]["DE"], fixture["channels"]["DE"], rtol=1e-6)


def test_predict_gives_the_command_lines_diagnosis(fixture):
    report = pumptwin.predict(fixture["channels"], fs=12_000, rpm=1797)
    assert report["majority_class"] == "IR007"
    assert report["diagnosis"]["fault_type"] == "inner_race"
    assert len(report["windows"]) == 10
    # The drive end alone: the physics reads the drive end, so the type stands.
    alone = pumptwin.predict(fixture["channels"]["DE"], fs=12_000, rpm=1797)
    assert alone["diagnosis"]["fault_type"] == "inner_race"
    assert sorted(alone["missing_nodes"]) == ["BA", "FE"]


def test_white_noise_is_not_a_confident_fault():
    noise = np.random.default_rng(1).normal(0, 0.1, 24_000)
    report = pumptwin.predict(noise, fs=12_000, rpm=1797)
    assert report["diagnosis"]["fault_type"] == "normal"
    assert report["diagnosis"]["confidence"] < 0.6
    assert report["warnings"], "the network's class is not supported by the physics"


def test_twin_loop_reports_and_spectra(fixture):
    out = pumptwin.twin_loop(fixture["channels"]["DE"], fs=12_000, rpm=1797)
    r, s = out["report"], out["spectra"]
    assert r["fault"] == "inner_race"
    assert r["error_final"]["psd_log_rmse_db"] <= r["error_initial"]["psd_log_rmse_db"]
    assert s["psd_freq_hz"].shape == s["psd_final_db"].shape == s["psd_measured_db"].shape
    assert s["env_freq_hz"].shape == s["env_final"].shape
    assert np.all(np.isfinite(s["psd_final_db"])) and np.all(np.diff(s["psd_freq_hz"]) > 0)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: pumptwin.predict(np.zeros(100), fs=12_000, rpm=1797), "shorter than one window"),
        (lambda: pumptwin.predict(np.full(4096, np.nan), fs=12_000, rpm=1797), "not finite"),
        (lambda: pumptwin.predict(np.ones(4096), fs=12_000, rpm=-5), "rpm"),
        (lambda: pumptwin.predict(np.ones(4096), fs=12_000, rpm=1797, bearing="6205"), "bearing"),
        (lambda: pumptwin.predict({"DE": np.ones(4096), "FE": np.ones(10)}, fs=12_000, rpm=1797),
         "different lengths"),
        (lambda: pumptwin.read(DATA / "nope.tdms"), "nope.tdms"),
        (lambda: pumptwin.read(DATA / "README.md"), "unsupported file type"),
    ],
)
def test_bad_input_is_a_value_error_with_its_reason(call, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        call()


def test_example_prints_the_readmes_figures():
    out = subprocess.run(
        [sys.executable, str(ROOT / "python/examples/cwru_diagnosis.py")],
        check=True, capture_output=True, text=True,
    ).stdout
    readme = (ROOT / "README.md").read_text()
    for line in out.splitlines():
        assert line in readme, f"the README does not show the example's line: {line}"
