#!/usr/bin/env python3
"""How often the loop's fault hypothesis would be right on a synthetic bench run if its
own envelope rule (`first_fit::identify_fault`) needed a higher level on records the
core diagnosis calls normal: per level, the hypotheses right, and every such case with
its best family's level. The run must keep every loop's report:
  ids=$(python3 -c "print(','.join(map(str, range(300))))")
  pumptwin twin bench --cases 300 --seed 7 --out DIR --only "$ids" --reports
  python3 scripts/fault-hypothesis-threshold.py DIR"""
import json, sys, os
d = sys.argv[1]
cases = [json.loads(l) for l in open(os.path.join(d, 'cases.jsonl'))]
rows = []
for c in cases:
    cid = c['case']['id']
    ev = json.load(open(os.path.join(d, f'case-{cid}.json'))).get('fault_evidence', {})
    lvl = max(ev.get(k, -99) for k in ('bpfo_db', 'bpfi_db', 'bsf_db'))
    rows.append((cid, ev.get('diagnosis'), lvl, c['fault_claimed'], c['fault_true'], c['fault_right']))
print('cases', len(rows), 'right now', sum(r[5] for r in rows))
normal = [r for r in rows if r[1] == 'normal']
print('diagnosis normal on', len(normal), ': truth none', sum(r[4] == 'none' for r in normal))
for r in sorted(normal, key=lambda r: r[2]):
    print(f'  case {r[0]:3} level {r[2]:6.2f} claimed {r[3]:11} truth {r[4]:11} right {r[5]}')
for t in [5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]:
    right = 0
    for cid, diag, lvl, claimed, truth, ok in rows:
        if diag == 'normal' and lvl < t:
            right += truth == 'none'
        else:
            right += ok
    print(f'T {t:2} dB: right {right}')
