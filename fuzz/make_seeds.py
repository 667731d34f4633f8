#!/usr/bin/env python3
"""Write the hand-made seed inputs under fuzz/seeds/ (run from anywhere; stdlib only)."""
import os, random, re, struct, zlib

os.chdir(os.path.dirname(os.path.abspath(__file__)))
for t in ("candump_log", "frame_decode", "sensor_map_toml", "dbc", "model_file", "csv", "mat", "wav"):
    os.makedirs(f"seeds/{t}", exist_ok=True)


def pad8(b): return b + b"\0" * ((-len(b)) % 8)
def el(t, data, o="<"): return struct.pack(o + "II", t, len(data)) + pad8(data)
def small(t, data): return struct.pack("<HH", t, len(data)) + data + b"\0" * (4 - len(data))


def matrix(name, vals, cls=6, dtype=9, fmt="d"):
    body = el(6, struct.pack("<II", cls, 0)) + el(5, struct.pack("<ii", len(vals), 1))
    body += small(1, name.encode()) if len(name) <= 4 else el(1, name.encode())
    body += el(dtype, b"".join(struct.pack("<" + fmt, v) for v in vals))
    return el(14, body)


# MAT level 5: a plain file, a compressed variable, big-endian.
hdr = b"MATLAB 5.0 MAT-file, pumptwin fuzz seed".ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x0100) + b"IM"
a = matrix("X105_DE_time", [0.1 * i for i in range(8)])
b = matrix("RPM", [1797.0])
c = matrix("X105_FE_time", [-5, 25, 125], dtype=3, fmt="h")  # double class, int16 storage
open("seeds/mat/plain.mat", "wb").write(hdr + a + b + c)
comp = zlib.compress(a)
open("seeds/mat/compressed.mat", "wb").write(hdr + struct.pack("<II", 15, len(comp)) + comp + b)
hdr_be = b"MATLAB 5.0 MAT-file, big endian".ljust(116, b" ") + b"\0" * 8 + struct.pack(">H", 0x0100) + b"MI"
body = (el(6, struct.pack(">II", 6, 0), ">") + el(5, struct.pack(">ii", 2, 1), ">")
        + el(1, b"ab", ">") + el(9, struct.pack(">dd", 1.0, 2.0), ">"))
open("seeds/mat/bigendian.mat", "wb").write(hdr_be + el(14, body, ">"))

# Model file: the shipped file, and its payload alone (the target frames it with a CRC).
m = open("../models/dsstgat-cwru-tb.ptm", "rb").read()
open("seeds/model_file/shipped.ptm", "wb").write(m)
L = struct.unpack("<I", m[10:14])[0]
open("seeds/model_file/shipped.payload", "wb").write(m[14:14 + L])

# CSV: the head of the shipped test record, other delimiters, one column, CRLF.
lines = open("../tests/data/cwru105_1s.csv").read().splitlines()
open("seeds/csv/cwru105_head.csv", "w").write("\n".join(lines[:40]) + "\n")
open("seeds/csv/semicolon.csv", "w").write("# c\nA;B\n1;2\n3e-2;-4.5\n")
open("seeds/csv/single.csv", "w").write("X\n1\n2\n")
open("seeds/csv/tab.csv", "w").write("X\tY\r\n1\t2\r\n")

# candump: the demo's first lines and every frame kind.
dl = open("../models/demo.log").read().splitlines()
open("seeds/candump_log/demo_head.log", "w").write("\n".join(dl[:6]) + "\n")
open("seeds/candump_log/kinds.log", "w").write("""# comment
(1700000000.000000) can0 123#DEADBEEF
(1700000000.000100) can0 12345678#0102
(1700000000.000200) vcan0 7FF#R
(1700000000.000300) can0 100#R8
(1700000000.000400) can0 20000080#0000000000000000
(1700000000.000500) can0 101##1000102030405060708090A0B
(1700000000.000600) can0 101##3
(1700000000.000700) can0 0x1#00 trailing
(170000000) can0 1#
""")

# frame_decode: records [sel, dt, len, rep, payload...] (see fuzz_targets/frame_decode.rs).
random.seed(7)
def rec(sel, dt, payload, rep=0, back=False):
    return bytes([sel, dt, len(payload) | (0x80 if back else 0), rep]) + payload
def noise(n): return bytes(random.randrange(256) for _ in range(n))
seq = b""
for k in range(40):
    for sel in (0x10, 0x12):
        seq += rec(sel, 26, bytes([k & 0xFF]) + noise(62) + b"\0")
    seq += rec(0x0C, 26, noise(8))
seq += rec(5, 1, bytes([0x14, 0x1C, 0x26, 0x02, 0x10, 0x68, 0, 0]))
seq += rec(0xE0, 0, b"") + rec(0xC0, 3, b"") + rec(6, 9, b"\1\2", back=True)
open("seeds/frame_decode/mixed.bin", "wb").write(seq)
# Enough samples for windows: each channel's frame repeated (counter incremented).
win = b""
for _ in range(3):
    win += rec(0x10, 26, bytes([0]) + noise(62) + b"\0", rep=60)
    win += rec(0x12, 26, bytes([0]) + noise(62) + b"\0", rep=60)
    win += rec(0x0C, 3, noise(8), rep=250)
seq = win
open("seeds/frame_decode/windows.bin", "wb").write(seq)

# Sensor maps and the DBC file.
open("seeds/sensor_map_toml/cwru.toml", "w").write(open("../models/cwru-sensors.toml").read())
src = open("fuzz_targets/frame_decode.rs").read()
open("seeds/sensor_map_toml/dbc_extended.toml", "w").write(re.search(r'const MAP: &str = r#"(.*?)"#;', src, re.S).group(1))
open("seeds/sensor_map_toml/custom_bearing.toml", "w").write("""[machine]
rpm = 1500
bearing = { n = 9, d = 7.94, pitch = 39.04, angle = 0.0 }
fs_hz = 25600

[[channel]]
name = "X"
can_id = 0x200
samples_per_frame = 3
scale = 0.001
""")
open("seeds/dbc/pump.dbc", "w").write(open("seeds/pump.dbc").read())

# WAV: 16-bit mono and 24-bit stereo at 12 kHz (the stdlib's wave writer).
import math, wave
for name, ch, width in [("mono16", 1, 2), ("stereo24", 2, 3)]:
    with wave.open(f"seeds/wav/{name}.wav", "wb") as w:
        w.setnchannels(ch)
        w.setsampwidth(width)
        w.setframerate(12000)
        frames = b""
        for i in range(64):
            for c in range(ch):
                v = int(0.5 * math.sin(i * 0.3 + c) * (2 ** (8 * width - 1) - 1))
                frames += v.to_bytes(width, "little", signed=True)
        w.writeframes(frames)
