#!/usr/bin/env python3
"""Compare the firmware's JOINTS.csv with the host's `kincal compensate` output.

Usage: compare_joints.py FIRMWARE.csv HOST.csv [--tolerance T] [--quiet]

Row by row, in order, matched by id:
  - the firmware answered every row exactly once, and its sequence numbers are
    1, 2, 3, ... (no point lost);
  - where the host compensated (status ok), the firmware did too and every
    joint command agrees within T (mm for prismatic, rad for revolute joints);
  - where the host refused (status e.g. "out of limits", no q), the firmware
    gives the same status and flags its output as held.
Prints the largest difference per joint and exits 1 on any mismatch.
"""

import argparse
import csv
import sys


def read(path):
    with open(path, newline="", encoding="utf-8") as f:
        lines = [l for l in f if l.strip() and not l.startswith("#")]
    return list(csv.DictReader(lines))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("firmware")
    ap.add_argument("host")
    ap.add_argument("--tolerance", type=float, default=1e-9)
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args()
    fw, host = read(a.firmware), read(a.host)
    errors = []
    if len(fw) != len(host):
        errors.append(f"{len(fw)} firmware rows, {len(host)} host rows")
    worst = [0.0] * 6
    compared = 0
    for k, (f, h) in enumerate(zip(fw, host)):
        where = f"row {k + 1} ('{h['id']}')"
        if f["id"] != h["id"]:
            errors.append(f"{where}: firmware id '{f['id']}'")
            continue
        if int(f["seq"]) != k + 1:
            errors.append(f"{where}: sequence number {f['seq']}, expected {k + 1}")
        h_status = h.get("status") or "ok"
        if f["status"] != h_status:
            errors.append(f"{where}: firmware status '{f['status']}', host '{h_status}'")
            continue
        if h_status != "ok":
            if "held" not in f["flags"].split("|"):
                errors.append(f"{where}: refused but not held (flags '{f['flags']}')")
            continue
        compared += 1
        for j in range(6):
            d = abs(float(f[f"q{j + 1}"]) - float(h[f"q{j + 1}"]))
            worst[j] = max(worst[j], d)
            if not d <= a.tolerance:
                errors.append(f"{where}: q{j + 1} differs by {d:.3e} (tolerance {a.tolerance:g})")
    if not a.quiet or errors:
        print(f"compare_joints: {len(fw)} rows, {compared} compensated by both; largest |q_fw - q_host|: "
              + ", ".join(f"q{j + 1} {w:.2e}" for j, w in enumerate(worst)))
    for e in errors[:20]:
        print("  MISMATCH " + e)
    if errors:
        print(f"compare_joints: {len(errors)} mismatches")
        return 1
    print(f"compare_joints: firmware = host within {a.tolerance:g} (max {max(worst):.2e})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
