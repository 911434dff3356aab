#!/usr/bin/env python3
"""Pose errors of a `kincal simulate` output (measured - commanded), per group.

Usage: pose_errors.py SIMULATED.csv [--prefix L2-] [--role test --poses POSES.csv]
                      [--label NAME] [--max-rms-um X] [--min-rms-um Y]

Position error |(mx, my, mz) - (x, y, z)| and orientation error (angle of
R_measured * R_commanded^T, R = Rz(rz) Ry(ry) Rx(rx)) over the rows whose id
starts with --prefix (all rows by default) and, with --role, whose row in
POSES.csv (the design, which has the `role` column) has that role. Prints one line; exits 1 if the
RMS position error is above --max-rms-um or below --min-rms-um.
"""

import argparse
import csv
import math
import sys


def rot(rx, ry, rz):
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
    return [[cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
            [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
            [-sy, cy * sx, cy * cx]]


def angle(a, b):
    # angle of A * B^T
    tr = sum(a[i][k] * b[i][k] for i in range(3) for k in range(3))
    return math.acos(max(-1.0, min(1.0, (tr - 1.0) / 2.0)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("simulated")
    ap.add_argument("--prefix", default="")
    ap.add_argument("--role")
    ap.add_argument("--poses")
    ap.add_argument("--label", default="")
    ap.add_argument("--max-rms-um", type=float)
    ap.add_argument("--min-rms-um", type=float)
    a = ap.parse_args()
    with open(a.simulated, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(l for l in f if l.strip() and not l.startswith("#")))
    wanted = None
    if a.role:
        with open(a.poses, newline="", encoding="utf-8") as f:
            design = csv.DictReader(l for l in f if l.strip() and not l.startswith("#"))
            wanted = {r["id"] for r in design if r.get("role") == a.role}
    dp, dth = [], []
    for r in rows:
        if not r["id"].startswith(a.prefix) or (r.get("status") or "ok") != "ok":
            continue
        if wanted is not None and r["id"] not in wanted:
            continue
        p = [float(r[c]) for c in ("x", "y", "z")]
        m = [float(r[c]) for c in ("mx", "my", "mz")]
        dp.append(math.dist(p, m) * 1e3)
        dth.append(angle(rot(*(float(r[c]) for c in ("mrx", "mry", "mrz"))),
                         rot(*(float(r[c]) for c in ("rx", "ry", "rz")))) * 1e6)
    if not dp:
        print(f"pose_errors: no rows with prefix '{a.prefix}'{' and role ' + a.role if a.role else ''} in {a.simulated}")
        return 1
    rms = math.sqrt(sum(x * x for x in dp) / len(dp))
    print(f"pose_errors {a.label or a.simulated}: {len(dp)} nodes, position rms {rms:.3f} um, "
          f"max {max(dp):.3f} um; orientation max {max(dth):.3f} urad")
    if a.max_rms_um is not None and not rms <= a.max_rms_um:
        print(f"pose_errors: rms {rms:.3f} um above {a.max_rms_um} um")
        return 1
    if a.min_rms_um is not None and not rms >= a.min_rms_um:
        print(f"pose_errors: rms {rms:.3f} um below {a.min_rms_um} um")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
