#!/usr/bin/env python3
"""Static worst-case stack of a firmware ELF (docs/benchmarks.md, "Firmware footprint").

Usage:
  scripts/stack_usage.py ELF --ci DIR [--su DIR ...] [--runtime-log FILE]
                         [--nm arm-none-eabi-nm] [--objdump ...] [--cxxfilt ...]

The worst case is the largest sum of frame sizes over the call paths from the
entry points (Reset_Handler, which calls main, and the .init_array constructors
it runs). Sources, best first, for each function in the linked image:
  1. GCC's -fcallgraph-info=su (.ci files under --ci): frame size AND call edges,
     after optimisation (what was really emitted, inlining done);
  2. -fstack-usage (.su files under --su) for the frame, call edges from the
     disassembly: the run-time objects, which are compiled without .ci;
  3. neither (newlib, libm, libgcc): frame from the disassembly (every push /
     stmdb sp! / vpush / sub sp of the function, summed), call edges from the
     disassembly.
The disassembly estimate is cross-checked against GCC on every function that
has both, and the agreement is printed, so the reader knows how far to trust (3).

Anything that makes the bound unsafe is reported and makes the result
"unbounded": a reachable indirect call other than the startup's .init_array
loop, reachable recursion, a dynamic frame (alloca / VLA, or sp moved by a
register), or a callee missing from the image. Exception handlers are not
entry points: this image enables no interrupt, see the printed note.

The last line is machine-readable:  RESULT worst_case_stack=<bytes|unbounded>
If --runtime-log is given (the qemu output, which the start-up code ends with
"kincal firmware: stack used N of M bytes"), the measured high-water mark is
printed too, and a static bound BELOW the measurement is an error (exit 1):
the analysis would then be missing something.
"""

import argparse
import os
import re
import subprocess
import sys

# ---------------------------------------------------------------- inputs --


def find_files(dirs, suffix):
    out = []
    for d in dirs:
        for root, _, files in os.walk(d):
            out += [os.path.join(root, f) for f in files if f.endswith(suffix)]
    return sorted(out)  # deterministic order


CI_NODE = re.compile(r'^node: \{ title: "([^"]*)" label: "((?:[^"\\]|\\.)*)"')
CI_EDGE = re.compile(r'^edge: \{ sourcename: "([^"]*)" targetname: "([^"]*)"')
CI_FRAME = re.compile(r"\\n(\d+) bytes \(([^)]*)\)")


def read_ci(paths):
    """.ci (VCG) files -> {asm name: frame}, {asm name: [callee]}, {asm name: qualifier}.

    Titles of functions defined in the unit are "<unit path>:<asm name>";
    external callees are plain "<asm name>" and carry no frame.
    """
    frame, calls, qual = {}, {}, {}
    for path in paths:
        unit = None
        for line in open(path, encoding="utf-8", errors="replace"):
            if line.startswith("graph:"):
                unit = re.search(r'title: "([^"]*)"', line).group(1) + ":"
                continue
            name = lambda t: t[len(unit):] if unit and t.startswith(unit) else t
            m = CI_NODE.match(line)
            if m:
                f = CI_FRAME.search(m.group(2))
                if f:  # a function emitted in this unit
                    frame[name(m.group(1))] = int(f.group(1))
                    qual[name(m.group(1))] = f.group(2)
                    calls.setdefault(name(m.group(1)), [])
                continue
            m = CI_EDGE.match(line)
            if m:
                calls.setdefault(name(m.group(1)), []).append(name(m.group(2)))
    return frame, calls, qual


SU_LINE = re.compile(r"^(.*?):(\d+):(\d+):(.*)\t(\d+)\t(\S+)$")


def read_su(paths):
    """-fstack-usage files -> {name: (frame, qualifier)}. For C the name is the
    symbol; for C++ it is a pretty name that does not match a symbol, so only C
    entries (plain identifiers) are used."""
    out = {}
    for path in paths:
        for line in open(path, encoding="utf-8", errors="replace"):
            m = SU_LINE.match(line.rstrip("\n"))
            if m and re.fullmatch(r"[A-Za-z_]\w*", m.group(4)):
                out[m.group(4)] = (int(m.group(5)), m.group(6))
    return out


def run(cmd, stdin=None):
    return subprocess.run(cmd, input=stdin, capture_output=True, text=True, check=True).stdout


FUNC_HDR = re.compile(r"^([0-9a-f]+) <(.+)>:$")
INSN = re.compile(r"^\s+[0-9a-f]+:\s+(\S+)\s*(.*)$")
BRANCH = re.compile(r"^(b|bl|blx|b\.n|b\.w|b(?:eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le)(?:\.n|\.w)?)$")
REG_LIST = re.compile(r"\{([^}]*)\}")


def reg_count(text):
    """Registers in "{r4, r5, lr}" or "{d8-d11}"."""
    n = 0
    for part in REG_LIST.search(text).group(1).split(","):
        part = part.strip()
        if "-" in part:
            a, b = (int(re.sub(r"\D", "", x)) for x in part.split("-"))
            n += b - a + 1
        elif part:
            n += 1
    return n


def disassemble(objdump, elf, functions):
    """Per function: call targets (direct, incl. tail branches), indirect call
    sites, frame estimate, and whether sp is ever set from a register."""
    info, cur = {}, None
    for line in run([objdump, "-d", "--no-show-raw-insn", elf]).splitlines():
        m = FUNC_HDR.match(line)
        if m:
            cur = m.group(2)
            info[cur] = {"calls": [], "indirect": 0, "frame": 0, "dynamic": False}
            continue
        m = INSN.match(line)
        if not m or cur is None:
            continue
        op, args, fi = m.group(1), m.group(2), info[cur]
        # Direct branch to the start of another function: a call or a tail call.
        t = re.search(r"<([^+>]+)>\s*$", args)
        if BRANCH.match(op) and t and t.group(1) != cur and t.group(1) in functions:
            fi["calls"].append(t.group(1))
        if op == "blx" and not t or op == "bx" and not args.startswith("lr") or op == "mov" and args.startswith("pc,"):
            fi["indirect"] += 1
        if re.match(r"^(mov|add|sub)(\.w|w)?$", op) and re.match(r"sp,\s*(sp,\s*)?r\d", args):
            fi["dynamic"] = True  # sp computed from a register: alloca / VLA / stack switch
        # Frame: every push and sp decrement in the function, summed. Library code
        # is shrink-wrapped (cos pushes only after an early-return test), so
        # stopping at the first branch would undercount; summing all of them can
        # only overcount (two prologues on alternative paths), which is safe.
        if op in ("push", "push.w") or (op == "stmdb" and args.startswith("sp!")):
            fi["frame"] += 4 * reg_count(args)
        elif op == "vpush":
            fi["frame"] += (8 if "d" in args else 4) * reg_count(args)
        elif re.match(r"^sub(\.w|w)?$", op) and re.match(r"sp,\s*(sp,\s*)?#\d+", args):
            fi["frame"] += int(re.search(r"#(\d+)", args).group(1))
        elif re.match(r"^str(\.w)?$", op) and re.search(r"\[sp, #-(\d+)\]!", args):
            fi["frame"] += int(re.search(r"\[sp, #-(\d+)\]!", args).group(1))
    return info


def demangle(cxxfilt, names):
    names = sorted(set(names))
    out = run([cxxfilt], stdin="\n".join(names) + "\n").splitlines()
    return dict(zip(names, out)) if len(out) == len(names) else {n: n for n in names}


def short(text, width=110):
    return text if len(text) <= width else text[: width - 3] + "..."


# -------------------------------------------------------------- analysis --


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("elf")
    ap.add_argument("--ci", action="append", default=[], help="directory searched for .ci files")
    ap.add_argument("--su", action="append", default=[], help="directory searched for .su files")
    ap.add_argument("--runtime-log", help="qemu output with the 'stack used N of M bytes' line")
    ap.add_argument("--nm", default="arm-none-eabi-nm")
    ap.add_argument("--objdump", default="arm-none-eabi-objdump")
    ap.add_argument("--cxxfilt", default="arm-none-eabi-c++filt")
    a = ap.parse_args()

    # Functions really in the image (after --gc-sections), with their sizes.
    # Aliases (C1/C2 constructors share one body) are one function at one
    # address; objdump names it after one of them, GCC's .ci maybe the other.
    functions, at = {}, {}
    for line in run([a.nm, "-S", a.elf]).splitlines():
        p = line.split()
        if len(p) == 4 and p[2] in "TtWw":
            functions[p[3]] = int(p[1], 16)
            at.setdefault(int(p[0], 16), []).append(p[3])
    aliases = {n: sorted(names) for names in at.values() for n in names}
    dis = disassemble(a.objdump, a.elf, functions)
    for n, same in aliases.items():  # give every alias the disassembly of its body
        body = next((x for x in same if x in dis), None)
        if body:
            dis[n] = dis[body]
    ci_frame, ci_calls, ci_qual = read_ci(find_files(a.ci, ".ci"))
    for n, same in aliases.items():
        body = next((x for x in same if x in ci_frame), None)
        if body and n not in ci_frame:
            ci_frame[n], ci_calls[n], ci_qual[n] = ci_frame[body], ci_calls.get(body, []), ci_qual[body]
    su = read_su(find_files(a.su, ".su"))

    # .init_array entries: startup.c calls them through a pointer (the only
    # indirect call we can resolve), after its own prologue, before main.
    init_fns = []
    try:
        sect = run([a.objdump, "-s", "-j", ".init_array", a.elf])
        by_addr = {}
        for line in run([a.nm, a.elf]).splitlines():
            p = line.split()
            if len(p) == 3 and p[1] in "TtWw":
                by_addr[int(p[0], 16) & ~1] = p[2]
        for line in sect.splitlines():
            m = re.match(r"^\s*[0-9a-f]+ ((?:[0-9a-f]{8} ?){1,4})", line)
            if m:
                for word in m.group(1).split():
                    addr = int.from_bytes(bytes.fromhex(word), "little") & ~1
                    init_fns.append(by_addr.get(addr, "0x%x" % addr))
    except subprocess.CalledProcessError:
        pass  # no .init_array section

    # One table: name -> frame, frame source, callees, problems.
    frame, source, calls = {}, {}, {}
    problems = {}  # name -> text; only the reachable ones are reported
    agree, compared, under = 0, 0, []
    for fn in functions:
        d = dis.get(fn, {"calls": [], "indirect": 0, "frame": 0, "dynamic": False})
        if fn in ci_frame:
            frame[fn], source[fn], calls[fn] = ci_frame[fn], "ci", ci_calls.get(fn, [])
            compared += 1
            agree += d["frame"] == ci_frame[fn]
            if d["frame"] < ci_frame[fn]:
                under.append((fn, d["frame"], ci_frame[fn]))
            if ci_qual[fn] != "static":
                problems[fn] = "frame is %s (-fcallgraph-info)" % ci_qual[fn]
            continue
        if fn in su:
            frame[fn], source[fn] = su[fn][0], "su"
            compared += 1
            agree += d["frame"] == su[fn][0]
            if d["frame"] < su[fn][0]:
                under.append((fn, d["frame"], su[fn][0]))
            if su[fn][1] != "static":
                problems[fn] = "frame is %s (-fstack-usage)" % su[fn][1]
        else:
            frame[fn], source[fn] = d["frame"], "disasm"
            if d["dynamic"]:
                problems[fn] = "sp set from a register (dynamic frame, estimate unsafe)"
        calls[fn] = d["calls"]
        if d["indirect"]:
            if fn == "Reset_Handler" and init_fns:
                calls[fn] = calls[fn] + init_fns  # the .init_array loop
            else:
                problems[fn] = "%d indirect call(s) or jump(s), callee unknown" % d["indirect"]

    # Longest path by depth-first search; a node on the current path again is recursion.
    best, on_path, recursion = {}, set(), []

    def worst(fn):
        if fn in best:
            return best[fn]
        if fn not in frame:
            problems[fn] = "called but not in the image (no frame known)"
            best[fn] = (0, [fn])
            return best[fn]
        on_path.add(fn)
        deepest = (0, [])
        for c in sorted(set(calls[fn])):
            if c in on_path:
                recursion.append((fn, c))
                continue
            deepest = max(deepest, worst(c), key=lambda x: x[0])
        on_path.discard(fn)
        best[fn] = (frame[fn] + deepest[0], [fn] + deepest[1])
        return best[fn]

    roots = [r for r in ("Reset_Handler", "main") if r in functions]
    if not roots:
        sys.exit("stack_usage.py: neither Reset_Handler nor main in %s" % a.elf)
    results = {r: worst(r) for r in roots}

    reachable, todo = set(), list(roots)
    while todo:
        fn = todo.pop()
        if fn not in reachable:
            reachable.add(fn)
            todo += calls.get(fn, [])
    names = demangle(a.cxxfilt, list(reachable) + init_fns + [u[0] for u in under])

    # ----------------------------------------------------------- report --
    print("static worst-case stack of %s" % os.path.basename(a.elf))
    print("  functions reachable from %s: %d (frames: %d from -fcallgraph-info, %d from -fstack-usage, "
          "%d from the disassembly)" % (
              "/".join(roots), len(reachable),
              sum(source.get(f) == "ci" for f in reachable),
              sum(source.get(f) == "su" for f in reachable),
              sum(source.get(f) == "disasm" for f in reachable)))
    print("  disassembly estimate = GCC's frame size on %d of %d functions that have both, "
          "below it on %d (listed), above it (safe) on the rest" % (agree, compared, len(under)))
    for fn, est, gcc in under:
        print("    estimate %d < GCC %d: %s" % (est, gcc, short(names.get(fn, fn), 80)))
    if init_fns:
        print("  assumed: Reset_Handler's indirect calls are the .init_array entries: "
              + ", ".join(short(names.get(f, f), 60) for f in init_fns))
    print("  not counted: exception handlers (this image enables no interrupt). A port with")
    print("  interrupts adds, per preemption level, the deepest handler path plus the 104-byte")
    print("  exception frame with FP context (Cortex-M7, lazy FP stacking).")
    for r in roots:
        total, path = results[r]
        print("\n  worst path from %s: %d bytes" % (r, total))
        acc = 0
        for fn in path:
            acc += frame.get(fn, 0)
            print("    %6d %6d  %-6s %s" % (frame.get(fn, 0), acc, source.get(fn, "?"),
                                          short(names.get(fn, fn))))
    print("    (frame, running total, frame source, function)")

    bad = sorted((f, t) for f, t in problems.items() if f in reachable)
    for f, t in bad:
        print("  UNBOUNDED: %s: %s" % (short(names.get(f, f), 80), t))
    for caller, callee in sorted(set(recursion)):
        print("  UNBOUNDED: recursion %s -> %s" % (short(names.get(caller, caller), 60),
                                                  short(names.get(callee, callee), 60)))
    static = results["Reset_Handler" if "Reset_Handler" in results else "main"][0]
    bounded = not bad and not recursion

    status = 0
    if a.runtime_log:
        m = re.search(r"stack used (\d+) of (\d+) bytes", open(a.runtime_log, errors="replace").read())
        if not m:
            print("  runtime high-water mark: not found in %s" % a.runtime_log)
            status = 1
        else:
            used = int(m.group(1))
            print("\n  runtime high-water mark (stack paint, qemu run): %d of %s bytes; static bound %d "
                  "= %.2f x measured" % (used, m.group(2), static, static / used if used else 0.0))
            if bounded and static < used:
                print("  ERROR: the static bound is below the measurement: the analysis misses a path")
                status = 1
    print("RESULT worst_case_stack=%s" % (static if bounded else "unbounded"))
    return status


if __name__ == "__main__":
    sys.exit(main())
