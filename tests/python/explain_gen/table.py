"""Markdown table of a sweep log (NAIC_EXPLAIN_SWEEP_LOG lines): per case the seeds where the
hidden effect was named first, where every check passed, the median and worst parameter
error among the named seeds, and other significant findings; for noise only the seeds with
any finding. Usage: python -m explain_gen.table LOG.jsonl"""
import collections
import json
import sys

import numpy as np


def rows(path):
    cases = collections.OrderedDict()
    for line in open(path):
        d = json.loads(line)
        cases[d["case"]] = d  # the last run of a case wins
    return cases


def table(path):
    out = ["| case | seeds | named first | all checks | parameter error: median / worst (rel.) | other findings / noise-only findings |",
           "| --- | --- | --- | --- | --- | --- |"]
    for cid, d in rows(path).items():
        res = d["results"]
        n = len(res)
        if d["kw"].get("effect") is None:
            c = collections.Counter(f for r in res for f in r["findings"])
            bad = sum(1 for r in res if r["findings"])
            out.append(f"| {cid} | {n} | – | {n - bad}/{n} clean | – | **{bad}/{n}** with a finding: {dict(c) or '–'} |")
            continue
        named = sum(1 for r in res if r.get("named_first"))
        errs = collections.defaultdict(list)
        for r in res:
            for k, v in r["param_err"].items():
                errs[k].append(v["rel_err"])
        perr = "; ".join(f"{k} {np.median(v):.3f} / {np.max(v):.3f}" for k, v in errs.items()) or "–"
        firsts = collections.Counter(r["first"] for r in res if not r.get("named_first"))
        others = collections.Counter(f for r in res for f in r["findings"][1:])
        note = []
        if firsts:
            note.append(f"first instead: {dict(firsts)}")
        if others:
            note.append(f"after it: {dict(others)}")
        out.append(f"| {cid} | {n} | {named}/{n} | {d['n_ok']}/{n} | {perr} | {'; '.join(note) or '–'} |")
    return "\n".join(out)


if __name__ == "__main__":
    print(table(sys.argv[1]))
