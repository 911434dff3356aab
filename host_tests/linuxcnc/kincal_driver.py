#!/usr/bin/python3
# -*- coding: utf-8 -*-
"""kincal headless LinuxCNC driver ("display" program).

LinuxCNC's launcher (`linuxcnc -r config.ini`) loads HAL, starts the task and
motion controllers and then runs `[DISPLAY]DISPLAY -ini <inifile>` in the
foreground; when that program exits, the launcher shuts LinuxCNC down.  So a
plain Python script in place of the GUI gives a fully headless, scriptable
LinuxCNC.  This is the same trick LinuxCNC's own test suite uses.

What it does:
  1. waits for task to come up, ESTOP reset, machine ON;
  2. homes all joints (switchless/immediate homing configured in the INI);
  3. MDI mode; for each pose line x,y,z,a,b,c (mm, degrees) of $KINCAL_POSES
     sends `G1 X.. Y.. Z.. A.. B.. C.. F..`, waits until the move is done and
     the servo loop has settled;
  4. writes joint values to $KINCAL_OUT as CSV with repr() precision:
       stat_pos_j   linuxcnc.stat().joint[j]['output']  (= joint pos_cmd)
       stat_act_j   linuxcnc.stat().joint[j]['input']   (= joint pos_fb)
       pos_cmd_j    HAL pin joint.j.pos-cmd      (after kinematics, before comp)
       motor_cmd_j  HAL pin joint.j.motor-pos-cmd (= pos_cmd + comp + motor_offset)
       motor_off_j  HAL pin joint.j.motor-offset  (set by homing)
       comp_j       HAL pin joint.j.backlash-filt (comp/backlash actually applied)
       corr_j       HAL pin joint.j.backlash-corr (the table's value at the
                    commanded position and direction, which backlash-filt
                    slews toward)
     plus stat.actual_position (forward kinematics of the feedback) and
     genhexkins.fwd-kins-fail;
  5. exits (the launcher then stops LinuxCNC).

Must run with Debian's /usr/bin/python3: the linuxcnc and hal modules live in
/usr/lib/python3/dist-packages (a pyenv/venv python3 will not find them).
Inputs come from environment variables because the launcher only passes -ini.
"""

import csv
import os
import sys
import time

import hal
import linuxcnc

NJ = 6
TIMEOUT = float(os.environ.get("KINCAL_STEP_TIMEOUT", "30"))
FEED = os.environ.get("KINCAL_FEED", "100000")  # mm/min, clipped by INI limits
SETTLE = float(os.environ.get("KINCAL_SETTLE", "0.02"))  # s after in-position


def log(*a):
    print("kincal_driver:", *a, file=sys.stderr, flush=True)


s = linuxcnc.stat()
c = linuxcnc.command()
e = linuxcnc.error_channel()


def check_errors():
    """Print and return any operator/NML error messages from LinuxCNC."""
    msgs = []
    while True:
        m = e.poll()
        if not m:
            break
        kind, text = m
        msgs.append(text)
        log("LinuxCNC message (kind %d): %s" % (kind, text))
    return msgs


def wait_for(pred, what, timeout=TIMEOUT):
    t0 = time.time()
    while True:
        s.poll()
        if pred():
            return
        if time.time() - t0 > timeout:
            check_errors()
            raise RuntimeError("timeout waiting for " + what)
        time.sleep(0.002)


# hal.get_value() refuses to work ("Cannot call before creating component")
# unless this process has attached to HAL as a component first.
_halcomp = hal.component("kincal_driver")
_halcomp.ready()


def pin(name):
    # hal.get_value reads any pin/param/signal by name from the running HAL.
    return hal.get_value(name)


def main():
    poses_path = os.environ["KINCAL_POSES"]
    out_path = os.environ["KINCAL_OUT"]

    # Task may still be initialising when we start.
    wait_for(lambda: s.task_state in (linuxcnc.STATE_ESTOP,
                                      linuxcnc.STATE_ESTOP_RESET,
                                      linuxcnc.STATE_OFF,
                                      linuxcnc.STATE_ON), "task up")

    c.state(linuxcnc.STATE_ESTOP_RESET)
    c.wait_complete()
    c.state(linuxcnc.STATE_ON)
    c.wait_complete()
    wait_for(lambda: s.task_state == linuxcnc.STATE_ON, "machine on")

    # Home all joints.  With HOME_SEARCH_VEL = HOME_LATCH_VEL = 0 this only
    # sets joint position := HOME_OFFSET (motor_offset := fb - HOME_OFFSET).
    c.mode(linuxcnc.MODE_MANUAL)
    c.wait_complete()
    c.teleop_enable(0)          # homing is done in joint mode
    c.wait_complete()
    c.home(-1)
    c.wait_complete()
    wait_for(lambda: all(s.homed[j] for j in range(NJ)), "homing")

    c.mode(linuxcnc.MODE_MDI)
    c.wait_complete()
    wait_for(lambda: s.task_mode == linuxcnc.MODE_MDI, "MDI mode")
    # Errors so far come from startup, e.g. "joint N: too many compensation
    # entries" (table > 256 lines: the rest is silently dropped) or "joint N:
    # compensation values must increase".  Treat them as fatal: the numbers
    # would not be what the caller expects.
    # Before homing the simulated drives stand at 0, below the strut limits
    # the export writes: LinuxCNC says so ("Exceeded NEGATIVE soft limit",
    # and a hint to jog off it). Those are expected; anything else is not.
    startup_errors = [m for m in check_errors()
                      if "soft limit" not in m]
    if startup_errors and os.environ.get("KINCAL_ALLOW_ERRORS") != "1":
        raise RuntimeError("LinuxCNC startup errors: %r" % startup_errors)

    cols = ["i", "x", "y", "z", "a", "b", "c", "ok"]
    for key in ("stat_pos", "stat_act", "pos_cmd", "motor_cmd",
                "motor_off", "comp", "corr"):
        cols += ["%s_%d" % (key, j) for j in range(NJ)]
    cols += ["act_%s" % ax for ax in "xyzabc"] + ["fwd_kins_fail"]

    with open(poses_path, newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].lstrip().startswith("#")]
    # Skip a header line if present.
    if rows and not _isfloat(rows[0][0]):
        rows = rows[1:]

    with open(out_path, "w", newline="") as fo:
        w = csv.writer(fo)
        w.writerow(cols)
        for i, r in enumerate(rows):
            pose = [float(v) for v in r[:6]]
            # repr() keeps full double precision in the G-code words
            # (the interpreter parses them with strtod).
            cmd = "G1 X%r Y%r Z%r A%r B%r C%r F%s" % (*pose, FEED)
            c.mdi(cmd)
            rc = c.wait_complete(TIMEOUT)
            # wait_complete only says task accepted/ran the command; also
            # wait for the interpreter to be idle and motion in position.
            wait_for(lambda: s.interp_state == linuxcnc.INTERP_IDLE
                     and s.inpos and s.queue == 0, "move %d" % i)
            time.sleep(SETTLE)   # let backlash/comp filter reach its target
            s.poll()
            errs = check_errors()
            ok = int(rc == linuxcnc.RCS_DONE and not errs)
            row = [i] + pose + [ok]
            row += [s.joint[j]["output"] for j in range(NJ)]
            row += [s.joint[j]["input"] for j in range(NJ)]
            row += [pin("joint.%d.pos-cmd" % j) for j in range(NJ)]
            row += [pin("joint.%d.motor-pos-cmd" % j) for j in range(NJ)]
            row += [pin("joint.%d.motor-offset" % j) for j in range(NJ)]
            row += [pin("joint.%d.backlash-filt" % j) for j in range(NJ)]
            row += [pin("joint.%d.backlash-corr" % j) for j in range(NJ)]
            row += list(s.actual_position[:6])
            row += [int(bool(pin("genhexkins.fwd-kins-fail")))]
            w.writerow([repr(v) if isinstance(v, float) else v for v in row])
            if not ok:
                log("pose %d: %s -> not ok (rc=%r)" % (i, cmd, rc))

    c.state(linuxcnc.STATE_OFF)
    c.wait_complete()
    log("done, %d poses" % len(rows))


def _isfloat(v):
    try:
        float(v)
        return True
    except ValueError:
        return False


if __name__ == "__main__":
    try:
        main()
    except Exception as ex:  # exit non-zero so run_poses.sh can tell
        log("ERROR:", repr(ex))
        sys.exit(1)
