"""Markdown table of a sweep log (NAIC_EXPLAIN_SWEEP_LOG lines): per case the seeds where the
hidden effect was named first, where every check passed, the median and worst parameter
error among the named seeds, and other significant findings; for noise only the seeds with
any finding. Usage: python -m explain_gen.table LOG.jsonl
(`--known-fails LOG.jsonl`: the KNOWN_FAILS entries of the cases that missed the goal)"""
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
                errs[k].append(v["rel_err"] if "rel_err" in v else v["ratio"])  # ratio: share of the error left
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




def known_fails(path):
    """`KNOWN_FAILS` entries (test_explain_independent.py) for the cases of a sweep log that missed the goal."""
    out = []
    for cid, d in rows(path).items():
        res, n = d["results"], len(d["results"])
        bad = [r for r in res if not r["ok"]]
        if len(bad) <= n // 20:
            continue
        if d["kw"].get("effect") is None:
            c = collections.Counter(f for r in bad for f in r["findings"])
            why = f"noise only: a finding in {len(bad)}/{n} seeds ({dict(c)}); goal ≤ {n // 20}"
        else:
            named = sum(1 for r in res if r.get("named_first"))
            firsts = collections.Counter(r["first"] for r in res if not r.get("named_first"))
            errs = collections.defaultdict(list)
            for r in bad:
                for k, v in r["param_err"].items():
                    if not v["ok"]:
                        errs[k].append(f"{v['true']:.4g}→{v['est']:.4g}" if "true" in v else f"{v['ratio']:.3g} left")
            why = f"{d['n_ok']}/{n} seeds pass (goal ≥ {n - n // 20}); named first {named}/{n}"
            if firsts:
                why += f", first instead {dict(firsts)}"
            for k, v in errs.items():
                why += f"; {k} out of tolerance in {len(v)} (true→est: {', '.join(v[:4])})"
        out.append(f"    {cid!r}: ({why!r}, {bad[0]['seed']}),")
    return "\n".join(out)


if __name__ == "__main__":
    print(known_fails(sys.argv[2]) if sys.argv[1] == "--known-fails" else table(sys.argv[1]))
