"""Shared by the evidence scripts: the release `pumptwin` binary (built if missing), the
CWRU manifest, and the core's node features of one record (`pumptwin features`)."""
import csv
import json
import os
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def pumptwin():
    """Path of the release `pumptwin` binary; builds it when it is not there."""
    exe = os.path.join(ROOT, "target/release/pumptwin")
    if not os.path.exists(exe):
        subprocess.run(["cargo", "build", "--release", "-p", "pumptwin", "--bin", "pumptwin"],
                       cwd=ROOT, check=True)
    return exe


def manifest(data):
    """The rows of `DATA/MANIFEST.tsv`."""
    return list(csv.DictReader(open(os.path.join(data, "MANIFEST.tsv")), delimiter="\t"))


def record_features(data, row, tmp):
    """`pumptwin features` of one manifest row, as parsed JSON (`feature_names`, and per
    window `features_raw[segment][node][feature]`)."""
    out = os.path.join(tmp, "f.json")
    subprocess.run([pumptwin(), "features", "--input", os.path.join(data, row["file"]), "--out", out],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return json.load(open(out))
