#!/usr/bin/env python3
"""The one-line error contract, audited over every input file a command reads.

Usage: scripts/error_audit.py KINCAL [--work DIR] [--list] [--json OUT.json]

It makes several hundred bad inputs from the shipped examples (robot JSON,
measurement / poses CSV, PARAMS.csv, MODEL.json, plan candidates) by
mutations chosen here, not by the readers' code: every JSON leaf deleted,
retyped, set out of range, arrays shortened and lengthened, keys duplicated;
every CSV column dropped, every field of two rows emptied, made text, NaN,
1e999, '+-5'; rows duplicated, cut, added; files empty, header-only,
comment-only, truncated mid-line. Each runs through the commands that read
that file (simulate, robot, identify, diagnose, compensate, table, plan,
errors) and the answer is classified:

  accepted     exit 0 (a mutation the tool may well accept: 0.0 for 0.0 ...)
  positioned   one line 'kincal: FILE:LINE[:COL]: ...' naming the bad file
  file only    one line 'kincal: FILE: ...' naming the bad file, no line
  unplaced     one line that names no input file
  broken       more than one line besides warnings ('FILE:LINE: warning: ...'),
               no 'kincal: ' prefix, a crash, a signal,
               a time-out (60 s) or an exit status other than 0, 1, 2

A 'file only' answer is right where the fault is the whole file's (empty,
too few nodes, a rank-deficient design, a robot family mismatch); the mutations
that make such faults say so (whole=True), and a 'file only' answer to any
other mutation is counted against the contract, as are 'unplaced' and
'broken'. Exit status: 0 if nothing counts against it, 1 otherwise.
"""
import argparse
import collections
import json
import os
import re
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EX = os.path.join(ROOT, "examples")


class Case:
    def __init__(self, name, bad, args, whole=False):
        self.name, self.bad, self.args, self.whole = name, bad, args, whole


def run(kincal, args, cwd):
    try:
        p = subprocess.run([kincal] + args, cwd=cwd, capture_output=True, text=True, timeout=60,
                           errors="replace")
    except subprocess.TimeoutExpired:
        return None, "", "time-out"
    return p.returncode, p.stdout, p.stderr


def classify(code, err, bad):
    if code is None:
        return "broken", err
    if code == 0:
        return "accepted", ""
    lines = err.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    # Warnings may come first ('FILE:LINE: warning: ...'); the error is one last line.
    if code not in (1, 2) or not lines or not lines[-1].startswith("kincal: ") or \
            any(": warning: " not in l or l.startswith("kincal: ") for l in lines[:-1]):
        return "broken", err
    err = lines[-1]
    msg = err[len("kincal: "):]
    if msg.startswith(bad + ":"):
        rest = msg[len(bad) + 1:]
        return ("positioned" if re.match(r"\d+(:\d+)?: ", rest) else "file only"), err
    return "unplaced", err


# ---------------------------------------------------------------- JSON mutations
def leaves(node, path=()):
    if isinstance(node, dict):
        for k, v in node.items():
            yield from leaves(v, path + (k,))
        yield path, node
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from leaves(v, path + (i,))
        yield path, node
    else:
        yield path, node


def get_parent(doc, path):
    node = doc
    for p in path[:-1]:
        node = node[p]
    return node


def json_mutants(doc, limit_paths=None):
    """(label, text) pairs: each leaf deleted, retyped, made huge/negative/zero;
    each array shortened and lengthened; a duplicated key; nesting; truncation."""
    base = json.dumps(doc, indent=2)
    out = []
    for path, value in leaves(doc):
        if not path or (limit_paths and not any(str(path[0]) == l for l in limit_paths)):
            continue
        label = "/".join(str(p) for p in path)
        def with_value(v, tag):
            d = json.loads(base)
            get_parent(d, path)[path[-1]] = v
            out.append((label + " " + tag, json.dumps(d, indent=2)))
        if isinstance(get_parent(doc, path), dict):
            d = json.loads(base)
            del get_parent(d, path)[path[-1]]
            out.append((label + " deleted", json.dumps(d, indent=2)))
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            with_value("12", "as string")
            with_value(None, "null")
            with_value(-abs(value) - 1e6, "-1e6")
            with_value(abs(value) * 1e9 + 1e9, "1e9")
            with_value(0, "0")
        elif isinstance(value, str):
            with_value(7, "as number")
            with_value("no such " + value, "unknown text")
        elif isinstance(value, list):
            if value:
                with_value(value[:-1], "shortened")
                with_value(value + [value[-1]], "lengthened")
            with_value({}, "as object")
        elif isinstance(value, dict):
            with_value([], "as array")
    # Text-level faults.
    lines = base.split("\n")
    out.append(("truncated", "\n".join(lines[: len(lines) // 2])))
    out.append(("trailing comma", base.replace("\n}", ",\n}", 1) if base.endswith("}") else base + ","))
    first_key = next(iter(doc))
    out.append(("duplicate key", base[:-1].rstrip() + ",\n  " + json.dumps(first_key) + ": " +
                json.dumps(doc[first_key]) + "\n}"))
    out.append(("nan literal", re.sub(r"(: )(-?\d+\.\d+)", r"\1NaN", base, count=1)))
    out.append(("1e999", re.sub(r"(: )(-?\d+\.\d+)", r"\g<1>1e999", base, count=1)))
    out.append(("empty", ""))
    out.append(("not an object", "[1, 2, 3]\n"))
    return out


# ----------------------------------------------------------------- CSV mutations
def read_csv(path):
    lines = open(path).read().split("\n")
    comments = [l for l in lines if l.startswith("#")]
    body = [l for l in lines if l and not l.startswith("#")]
    return comments, body[0].split(","), [r.split(",") for r in body[1:]]


def write_csv(comments, header, rows):
    return "\n".join(comments + [",".join(header)] + [",".join(r) for r in rows]) + "\n"


def csv_mutants(path, rows_to_touch=(1, -2), skip_columns=()):
    comments, header, rows = read_csv(path)
    out = []
    for c, name in enumerate(header):
        h = header[:c] + header[c + 1:]
        out.append((f"column {name} dropped", write_csv(comments, h, [r[:c] + r[c + 1:] for r in rows]), False))
        if name in skip_columns:
            continue
        for ri in rows_to_touch:
            for tag, v in (("empty", ""), ("text", "abc"), ("nan", "nan"), ("inf", "1e999"),
                           ("two signs", "+-5"), ("quoted", '"1"x'), ("huge", "1e30")):
                rr = [list(r) for r in rows]
                rr[ri][c] = v
                out.append((f"row {ri} {name} {tag}", write_csv(comments, header, rr), False))
    out.append(("extra field", write_csv(comments, header, rows[:1] + [rows[1] + ["5"]] + rows[2:]), False))
    out.append(("missing field", write_csv(comments, header, rows[:1] + [rows[1][:-1]] + rows[2:]), False))
    out.append(("duplicate row", write_csv(comments, header, rows + [rows[0]]), False))
    out.append(("duplicate column", write_csv(comments, header + [header[-1]], [r + [r[-1]] for r in rows]), False))
    out.append(("header only", write_csv(comments, header, []), True))
    out.append(("empty", "", True))
    out.append(("comments only", "\n".join(comments) + "\n", True))
    out.append(("cut mid-line", write_csv(comments, header, rows)[:-9], False))
    out.append(("NUL byte", write_csv(comments, header, rows).replace(",", "\0,", 1), False))
    out.append(("two rows", write_csv(comments, header, rows[:2]), True))
    out.append(("one pose repeated", write_csv(comments, header, [[f"r{i}"] + rows[0][1:] if header[0] == "id" else rows[0]
                                                                     for i in range(len(rows))]), True))
    return out


# --------------------------------------------------------------------- the cases
def build_cases(kincal, work):
    os.makedirs(work, exist_ok=True)
    cases = []

    def put(name, text):
        p = os.path.join(work, name)
        with open(p, "w") as f:
            f.write(text)
        return p

    def ok(args):
        code, out, err = run(kincal, args, work)
        if code != 0:
            sys.exit(f"error_audit: setting up failed: kincal {' '.join(args)}: {err.strip()}")

    # Valid inputs the mutations start from, made by the tool itself.
    s_meas, h_meas = os.path.join(work, "s_meas.csv"), os.path.join(work, "h_meas.csv")
    ok(["simulate", "--robot", "stewart-seed001", "--poses", f"{EX}/seed001/diagnosis_poses.csv",
        "--errors", f"{EX}/seed001/errors.csv", "--noise-mm", "0.001", "--noise-rad", "5e-6", "--out", s_meas])
    ok(["simulate", "--robot", "hybrid-seed000", "--poses", f"{EX}/hybrid-seed000/poses.csv",
        "--errors", f"{EX}/hybrid-seed000/errors.csv", "--noise-mm", "0.005", "--out", h_meas])
    s_model, h_model = os.path.join(work, "s_model.json"), os.path.join(work, "h_model.json")
    ok(["identify", "--robot", "stewart-seed001", "--data", s_meas, "--out", s_model])
    ok(["identify", "--robot", "hybrid-seed000", "--data", h_meas, "--out", h_model])
    s_poses, h_poses = f"{EX}/seed001/grid_poses.csv", f"{EX}/hybrid-seed000/poses.csv"
    out = lambda n: os.path.join(work, "out_" + n)

    for fam, robot_file, poses in (("s", f"{EX}/robots/stewart-seed001.json", s_poses),
                                   ("h", f"{EX}/robots/hybrid-seed000.json", h_poses)):
        for i, (label, text) in enumerate(json_mutants(json.load(open(robot_file)))):
            p = put(f"{fam}_robot_{i}.json", text)
            cases.append(Case(f"robot {fam}: {label}", p, ["robot", "--robot", p]))
            cases.append(Case(f"simulate robot {fam}: {label}", p,
                              ["simulate", "--robot", p, "--poses", poses, "--out", out("sim.csv")]))

    for fam, model_file, robot, poses in (("s", s_model, "stewart-seed001", s_poses),
                                          ("h", h_model, "hybrid-seed000", h_poses)):
        # The model's own keys and parameters; the embedded robot was mutated above.
        for i, (label, text) in enumerate(json_mutants(json.load(open(model_file)),
                                                       limit_paths=("parameters", "format", "version", "family",
                                                                    "estimator", "machine", "effects"))):
            if label.startswith("parameters/") and not re.match(r"parameters/[0-2]/", label):
                continue  # three parameters stand for all of them
            p = put(f"{fam}_model_{i}.json", text)
            cases.append(Case(f"compensate model {fam}: {label}", p,
                              ["compensate", "--robot", robot, "--model", p, "--poses", poses, "--out", out("j.csv")]))
            cases.append(Case(f"table model {fam}: {label}", p, ["table", "--model", p, "--out", out("t.hpp")]))

    for fam, meas, robot in (("s", s_meas, "stewart-seed001"), ("h", h_meas, "hybrid-seed000")):
        for i, (label, text, whole) in enumerate(csv_mutants(meas)):
            p = put(f"{fam}_meas_{i}.csv", text)
            cases.append(Case(f"identify data {fam}: {label}", p,
                              ["identify", "--robot", robot, "--data", p, "--out", out("m.json")], whole))
            if fam == "s" or "dropped" in label or label in ("empty", "header only", "two rows"):
                # The hybrid diagnosis takes seconds: its data faults are read by the same reader.
                cases.append(Case(f"diagnose data {fam}: {label}", p,
                                  ["diagnose", "--robot", robot, "--data", p, "--json", out("d.json"),
                                   "--noise-um", "1" if fam == "s" else "5", "--quiet"], whole))
            cases.append(Case(f"errors data {fam}: {label}", p, ["errors", "--data", p], whole))

    for fam, poses, robot, model in (("s", s_poses, "stewart-seed001", s_model), ("h", h_poses, "hybrid-seed000", h_model)):
        for i, (label, text, whole) in enumerate(csv_mutants(poses, rows_to_touch=(0,))):
            p = put(f"{fam}_poses_{i}.csv", text)
            cases.append(Case(f"simulate poses {fam}: {label}", p,
                              ["simulate", "--robot", robot, "--poses", p, "--out", out("s.csv")], whole))
            cases.append(Case(f"compensate poses {fam}: {label}", p,
                              ["compensate", "--robot", robot, "--model", model, "--poses", p, "--out", out("j.csv")],
                              whole))
    # Poses beyond the workspace, and past the robot file's limits.
    far = put("s_far.csv", "id,x,y,z,rx,ry,rz\na,0,0,200,0,0,0\nb,0,0,900,0,0,0\nc,0,0,150,0,0,0\n")
    cases.append(Case("simulate poses s: unreachable rows", far,
                      ["simulate", "--robot", "stewart-seed001", "--poses", far, "--out", out("s.csv")]))
    cases.append(Case("plan candidates s: unreachable rows", far,
                      ["plan", "--robot", "stewart-seed001", "--count", "30", "--candidates", far, "--out", out("p.csv"),
                       "--quiet"], True))

    for fam, errors, robot, poses in (("s", f"{EX}/seed001/errors.csv", "stewart-seed001", s_poses),
                                      ("h", f"{EX}/hybrid-seed000/errors.csv", "hybrid-seed000", h_poses)):
        for i, (label, text, whole) in enumerate(csv_mutants(errors, rows_to_touch=(0,))):
            if label == "one pose repeated":
                label, whole = "a parameter listed twice", False
            p = put(f"{fam}_errors_{i}.csv", text)
            cases.append(Case(f"simulate errors {fam}: {label}", p,
                              ["simulate", "--robot", robot, "--poses", poses, "--errors", p, "--out", out("s.csv")],
                              whole))
    # Measurement without the columns its family needs, and the other family's data.
    cases.append(Case("identify data s: hybrid gauge data for a 6-UPS", h_meas,
                      ["identify", "--robot", "stewart-seed001", "--data", h_meas, "--out", out("m.json")], True))
    cases.append(Case("identify data h: 6-UPS pose data for a hybrid", s_meas,
                      ["identify", "--robot", "hybrid-seed000", "--data", s_meas, "--out", out("m.json")], True))
    cases.append(Case("compensate model h on a 6-UPS", h_model,
                      ["compensate", "--robot", "stewart-seed001", "--model", h_model, "--poses", s_poses,
                       "--out", out("j.csv")], True))
    return cases


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kincal")
    ap.add_argument("--work", default=None, help="scratch folder (default: a new one under /tmp)")
    ap.add_argument("--list", action="store_true", help="print every answer that counts against the contract")
    ap.add_argument("--json", help="write every case and its answer here")
    a = ap.parse_args()
    kincal = os.path.abspath(a.kincal)
    work = a.work or subprocess.run(["mktemp", "-d"], capture_output=True, text=True).stdout.strip()
    cases = build_cases(kincal, work)
    counts = collections.Counter()
    against = []
    rows = []
    for n, c in enumerate(cases):
        code, _, err = run(kincal, c.args, work)
        kind, msg = classify(code, err, c.bad)
        counts[kind] += 1
        bad = kind in ("broken", "unplaced") or (kind == "file only" and not c.whole)
        if bad:
            against.append((c.name, kind, msg.strip()))
        rows.append({"case": c.name, "class": kind, "whole_file": c.whole, "exit": code, "stderr": msg.strip(),
                     "against": bad})
        if (n + 1) % 100 == 0:
            print(f"error_audit: {n + 1}/{len(cases)} cases", file=sys.stderr)
    errors = sum(v for k, v in counts.items() if k != "accepted")
    print(f"error_audit: {len(cases)} bad inputs, {counts['accepted']} accepted, {errors} refused: "
          f"{counts['positioned']} with FILE:LINE[:COL], {counts['file only']} with FILE only, "
          f"{counts['unplaced']} naming no input file, {counts['broken']} broken; "
          f"{len(against)} against the contract")
    if a.list:
        for name, kind, msg in against:
            print(f"  [{kind}] {name}: {msg}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    if not a.work:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if against else 0


if __name__ == "__main__":
    sys.exit(main())
