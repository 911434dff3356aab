#!/usr/bin/env python3
"""Add the structure temperature to the firmware's JOINTS.csv for re-simulation.

Usage: with_temperature.py FIRMWARE.csv POSES.csv OUT.csv

The firmware reads `temp` from the NC stream but does not echo it; a machine
with a thermal effect can only be re-simulated on the firmware's commands with
the temperature each point was run at. The rows are matched by id; a firmware
row whose id the poses file lacks is an error.
"""

import csv
import sys


def rows(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(l for l in f if l.strip() and not l.startswith("#")))


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    fw, poses = rows(sys.argv[1]), rows(sys.argv[2])
    temp = {p["id"]: p["temp"] for p in poses if p.get("temp")}
    missing = [r["id"] for r in fw if r["id"] not in temp]
    if missing:
        sys.exit(f"with_temperature.py: no temp for firmware rows {missing[:5]} in {sys.argv[2]}")
    with open(sys.argv[3], "w", newline="", encoding="utf-8") as f:
        out = csv.DictWriter(f, fieldnames=list(fw[0].keys()) + ["temp"])
        out.writeheader()
        for r in fw:
            out.writerow({**r, "temp": temp[r["id"]]})
    print(f"{len(fw)} firmware rows with their temperature -> {sys.argv[3]}")


if __name__ == "__main__":
    main()
