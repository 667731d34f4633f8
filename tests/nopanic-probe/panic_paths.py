#!/usr/bin/env python3
"""List the call sites into Rust's panic machinery in a linked binary.

Usage: panic_paths.py OBJDUMP ELF

Reads `OBJDUMP -d -l -C` of the binary (built with line tables), finds every branch
to a function that can only end in the panic handler (`rust_begin_unwind`, found by
walking the call graph backwards), and prints, per call site outside those
functions, the enclosing function and the source line the branch came from. An empty
list means no panic is reachable.
"""
import os
import re
import subprocess
import sys
from collections import defaultdict

objdump, elf = sys.argv[1], sys.argv[2]
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))) + "/"
text = subprocess.run([objdump, "-d", "-l", "-C", "--no-show-raw-insn", elf],
                      check=True, capture_output=True, text=True).stdout

func_re = re.compile(r"^([0-9a-f]+) <(.*)>:$")
line_re = re.compile(r"^(/\S+|\S+\.rs):(\d+)")
call_re = re.compile(r"^\s*([0-9a-f]+):\s+(bl|blx|b|b\.w|bne\.w|beq\.w|b\w*)\s+[0-9a-f]+ <(.*?)(\+0x[0-9a-f]+)?>")

calls = []          # (caller, callee, source line)
callees = defaultdict(set)
func, src = None, "?"
for raw in text.splitlines():
    m = func_re.match(raw)
    if m:
        func, src = m.group(2), "?"
        continue
    m = line_re.match(raw)
    if m:
        src = f"{m.group(1)}:{m.group(2)}"
        continue
    m = call_re.match(raw)
    if m and func and m.group(3) != func:
        calls.append((func, m.group(3), m.group(1)))
        callees[func].add(m.group(3))

# Functions from which every path ends in the panic handler: the handler itself and
# core's panicking helpers (they do nothing but format and call it).
panicky = {f for f in callees if "rust_begin_unwind" in f}
panicky.add("__rustc::rust_begin_unwind")
core_panic = re.compile(r"^core::(panicking|slice::index::.*fail|option::unwrap_failed|option::expect_failed|result::unwrap_failed|str::slice_error_fail|cell::panic)")
changed = True
while changed:
    changed = False
    for f, cs in callees.items():
        if f not in panicky and core_panic.match(f) and cs & panicky:
            panicky.add(f)
            changed = True
for f in [f for f in callees] + ["core::panicking::panic_fmt"]:
    if core_panic.match(f):
        panicky.add(f)

sites = [(caller, callee, addr) for caller, callee, addr in calls
         if callee in panicky and caller not in panicky]
addr2line = objdump.replace("objdump", "addr2line")
report = set()
for caller, callee, addr in sites:
    # The inlining chain of the call site, innermost first; show it up to the first
    # frame in this repository's code.
    out = subprocess.run([addr2line, "-i", "-f", "-C", "-e", elf, addr],
                         check=True, capture_output=True, text=True).stdout.splitlines()
    frames = [(out[i], out[i + 1]) for i in range(0, len(out) - 1, 2)]
    chain = []
    for fn, loc in frames:
        loc = re.sub(r" \(discriminator \d+\)", "", loc)
        loc = loc.replace(REPO, "")
        loc = re.sub(r"^/rustc/[0-9a-f]+/library/", "rust:", loc)
        loc = re.sub(r"^.*/registry/src/[^/]+/", "", loc)
        chain.append(f"{loc} ({fn})")
        if loc.startswith(("core/src/", "tests/nopanic-probe/src/")):
            break
    report.add((chain[-1], " <- ".join(chain[:-1]), callee))
for own, inner, callee in sorted(report):
    print(own)
    if inner:
        print(f"    via {inner}")
    print(f"    -> {callee}")
print(f"{len(sites)} call site(s) into the panic machinery ({len(report)} distinct source lines)")
