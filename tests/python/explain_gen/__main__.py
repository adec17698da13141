"""python -m explain_gen --out DIR [--effect NAME] [--arm jk5|panda] [--excitation stepped|multisine|ptp]
[--rate-hz R] [--duration-s T] [--noise S] [--friction sign|tanh] [--q-s low|mid|high]
[--jitter none|small|controller] [--tip NAME] [--seed N]: writes one CSV (the `naic explain
--measured` time-series format) and its ground-truth JSON, and prints their paths and the
`naic explain` command line for them."""
import argparse
import dataclasses

from .generate import EFFECTS, Case, generate


def main():
    ap = argparse.ArgumentParser(prog="python -m explain_gen", description=__doc__.split(":")[0])
    ap.add_argument("--out", required=True, help="output directory")
    for f in dataclasses.fields(Case):
        kw = {"default": f.default, "help": f"(default {f.default})"}
        if f.name == "effect":
            kw["choices"] = EFFECTS
            kw["help"] = "hidden effect (default: none, noise only)"
        elif f.type in (float, "float") or f.name in ("rate_hz", "duration_s"):
            kw["type"] = float
        elif f.name == "noise":
            kw["type"] = float
            kw["help"] = "torque noise σ [N·m] (default: drawn in 0.02–0.08)"
        elif f.name == "seed":
            kw["type"] = int
        ap.add_argument("--" + f.name.replace("_", "-"), dest=f.name, **kw)
    a = vars(ap.parse_args())
    out = a.pop("out")
    csv, urdf, truth = generate(Case(**a), out)
    print(f"wrote {csv} ({truth['samples']} samples, noise σ = {truth['noise_sigma_nm']:.3f} N·m)")
    print(f"truth {csv.with_suffix('.json')}: {truth['effect'] or 'noise only'} {truth['params'] or ''}")
    print(f"naic explain --measured {csv} --urdf {urdf} --out {out}/report" + (f" --tip {a['tip']}" if a["tip"] != "tip" else ""))


if __name__ == "__main__":
    main()
