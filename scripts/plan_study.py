#!/usr/bin/env python3
"""Planned against grid poses, measured by simulation (issue #15; docs/plan.md).

For a robot: `kincal plan` chooses COUNT poses (and writes the grid of the
same size it compares with); a separate `kincal plan --test` run with another
seed gives held-out poses spread over the workspace. Then, for several hidden
error sets drawn here (uniform, every parameter of `kincal robot --params`)
and several noise draws each, both designs go through the tool as a user
would run it: simulate (hidden errors + noise) -> identify -> compensate the
held-out poses -> drive the erroneous machine with those joints (no noise)
-> RMS position error. Prints the mean and median over all runs, and for a
6-UPS the RMS error of the identified parameters against the truth.

A study, not a test: minutes of run time.

usage: scripts/plan_study.py KINCAL ROBOT COUNT [--sets 3] [--draws 8]
       [--effects E] [--measure pose|targets] [--noise-mm 0.005] [--noise-rad 2.5e-5]
       [--error-mm 0.2] [--error-rad 3e-4] [--test 60] [--work DIR]
"""
import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile


def run(args, **kw):
    r = subprocess.run(args, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        raise RuntimeError(" ".join(args) + ": " + r.stderr.strip().splitlines()[-1] if r.stderr else "failed")
    return r.stdout


def rms_position_um(kincal, path):
    out = run([kincal, "errors", "--data", path])
    for line in out.splitlines():
        f = line.split()
        if f and f[0] == "all":
            return float(f[4])
    raise RuntimeError("no 'all' row in kincal errors " + path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("kincal")
    ap.add_argument("robot")
    ap.add_argument("count", type=int)
    ap.add_argument("--sets", type=int, default=3)
    ap.add_argument("--draws", type=int, default=8)
    ap.add_argument("--effects", default="")
    ap.add_argument("--measure", default="")
    ap.add_argument("--noise-mm", type=float, default=0.005)
    ap.add_argument("--noise-rad", type=float, default=2.5e-5)
    ap.add_argument("--error-mm", type=float, default=0.2)
    ap.add_argument("--error-rad", type=float, default=3e-4)
    ap.add_argument("--test", type=int, default=60)
    ap.add_argument("--errors", default="", help="a fixed PARAMS.csv as the hidden errors (then --sets is 1)")
    ap.add_argument("--heldout", default="", help="held-out poses file (its test rows; default: kincal plan --test)")
    ap.add_argument("--candidates", default="", help="passed to kincal plan --candidates")
    ap.add_argument("--effect", action="append", default=[], help="a hidden effect NAME:PARAM=VALUE (simulate --effect)")
    ap.add_argument("--work", default="")
    a = ap.parse_args()
    if a.errors:
        a.sets = 1
    k = a.kincal
    work = a.work or tempfile.mkdtemp(prefix="plan-study-")
    os.makedirs(work, exist_ok=True)
    p = lambda n: os.path.join(work, n)

    plan_args = [k, "plan", "--robot", a.robot, "--count", str(a.count), "--quiet"]
    if a.effects:
        plan_args += ["--effects", a.effects]
    if a.measure:
        plan_args += ["--measure", a.measure]
    if a.candidates:
        plan_args += ["--candidates", a.candidates]
    print(run(plan_args + ["--out", p("planned.csv"), "--grid-out", p("grid.csv"), "--json", p("plan.json")]))
    if a.heldout:
        with open(a.heldout) as f, open(p("heldout_all.csv"), "w") as g:
            g.write("".join(l for l in f if not l.startswith("#")))
    else:
        run([k, "plan", "--robot", a.robot, "--count", str(a.count), "--test", str(a.test), "--seed", "777",
             "--quiet", "--out", p("heldout_all.csv")])
    with open(p("heldout_all.csv")) as f:
        lines = f.read().splitlines()
    with open(p("heldout.csv"), "w") as f:
        test_rows = [l for l in lines[1:] if ",test," in l]
        f.write("\n".join([lines[0]] + test_rows) + "\n")
    a.test = len(test_rows)

    names = [l.split("\t") for l in run([k, "robot", "--robot", a.robot, "--params"]).splitlines() if "\t" in l]
    rng = random.Random(12345)
    results = {"planned": [], "grid": []}
    param_err = {"planned": [], "grid": []}
    failures = {"planned": 0, "grid": 0}
    effect_values = {"planned": [], "grid": []}
    for s in range(a.sets):
        truth = {}
        if a.errors:
            text = open(a.errors).read()
            open(p(f"errors{s}.csv"), "w").write(text)
            for line in text.splitlines():
                f = line.split(",")
                if len(f) == 2 and not line.startswith("#") and f[0] != "name":
                    truth[f[0]] = float(f[1])
        else:
            with open(p(f"errors{s}.csv"), "w") as f:
                f.write("name,value\n")
                for n, unit, *_ in names:
                    v = rng.uniform(-1, 1) * (a.error_rad if unit == "rad" else a.error_mm)
                    truth[n] = v
                    f.write(f"{n},{v!r}\n")
        for d in range(a.draws):
            for design in ("planned", "grid"):
                tag = f"{design}{s}_{d}"
                try:
                    run([k, "simulate", "--robot", a.robot, "--poses", p(design + ".csv"), "--out", p(tag + "_m.csv"),
                         "--errors", p(f"errors{s}.csv"), "--noise-mm", str(a.noise_mm), "--noise-rad",
                         str(a.noise_rad), "--seed", str(1000 * s + d + 1)] + sum((["--effect", e] for e in a.effect), []))
                    ident = [k, "identify", "--robot", a.robot, "--data", p(tag + "_m.csv"), "--out",
                             p(tag + "_model.json")]
                    if a.effects:
                        ident += ["--effects", a.effects]
                    run(ident)
                    run([k, "compensate", "--robot", a.robot, "--model", p(tag + "_model.json"), "--poses",
                         p("heldout.csv"), "--out", p(tag + "_j.csv")])
                    run([k, "simulate", "--robot", a.robot, "--poses", p(tag + "_j.csv"), "--out", p(tag + "_r.csv"),
                         "--errors", p(f"errors{s}.csv")] + sum((["--effect", e] for e in a.effect), []))
                    results[design].append(rms_position_um(k, p(tag + "_r.csv")))
                    with open(p(tag + "_model.json")) as f:
                        model = json.load(f)
                    eff = model.get("effects", {})
                    if eff:
                        effect_values[design].append(eff)
                    diffs = [(q["value"] - truth[q["name"]]) * 1e3 for q in model.get("parameters", [])
                             if q.get("name") in truth and q.get("unit", "mm") == "mm"]
                    if diffs:
                        param_err[design].append((sum(x * x for x in diffs) / len(diffs)) ** 0.5)
                except RuntimeError as e:
                    failures[design] += 1
                    print(f"  {tag}: {e}", file=sys.stderr)
            print(f"  set {s + 1}/{a.sets} draw {d + 1}/{a.draws}: planned {results['planned'][-1]:.2f} um, "
                  f"grid {results['grid'][-1]:.2f} um" if results["planned"] and results["grid"] else "", file=sys.stderr)

    print(f"{a.robot}, {a.count} poses, {a.sets} hidden error sets x {a.draws} noise draws "
          f"(noise {a.noise_mm * 1e3:g} um / {a.noise_rad * 1e6:g} urad), {a.test} held-out poses; work dir {work}")
    print(f"{'design':<10}{'runs':>6}{'failed':>8}{'held-out mean um':>18}{'median um':>12}{'param RMS um':>14}")
    for design in ("planned", "grid"):
        r = results[design]
        pe = param_err[design]
        print(f"{design:<10}{len(r):>6}{failures[design]:>8}{statistics.mean(r) if r else float('nan'):>18.2f}"
              f"{statistics.median(r) if r else float('nan'):>12.2f}"
              f"{statistics.mean(pe) if pe else float('nan'):>14.2f}")
    for design in ("planned", "grid"):
        if effect_values[design]:
            print(f"{design} identified effects (first runs): " + "; ".join(json.dumps(e) for e in effect_values[design][:3]))
    if results["planned"] and results["grid"]:
        print(f"planned / grid (mean): {statistics.mean(results['planned']) / statistics.mean(results['grid']):.3f}")


if __name__ == "__main__":
    main()
