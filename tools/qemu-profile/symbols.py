#!/usr/bin/env python3
"""Instructions per function from profile.c's epochs.

symbols.py ELF PROFILE LOG [SELECT] [TOP]

SELECT picks the epochs: the line numbers of LOG (the firmware's output, one epoch ending at
each line it printed) as `4` or `1,2,3`, or a text the lines contain (`bench plan four_holes`:
the epoch that ended with that line); without it, all of them. The bench firmware computes a
slice's phases and then prints them, so the work is in the epochs ending at its `slice`,
`layer` and first `bench` lines: run.sh prints which epoch holds how much.
"""
import bisect
import collections
import subprocess
import sys


def main():
    elf, prof, log = sys.argv[1:4]
    select = sys.argv[4] if len(sys.argv) > 4 else ""
    top = int(sys.argv[5]) if len(sys.argv) > 5 else 30
    nm = subprocess.run(["nm", "-C", "-n", "-S", "--defined-only", elf],
                        capture_output=True, text=True, check=True).stdout
    syms = []
    for line in nm.splitlines():
        parts = line.split(None, 3)
        if len(parts) == 4 and parts[2] in "tTwW":
            syms.append((int(parts[0], 16), int(parts[1], 16), parts[3]))
    syms.sort()
    starts = [s[0] for s in syms]
    lines = [l.rstrip("\n") for l in open(log) if l.strip()]
    if not select:
        want = None
    elif select[0].isdigit():
        want = {int(x) for x in select.split(",")}
    else:
        want = {i for i, l in enumerate(lines) if select in l}
    per_fn = collections.Counter()
    per_epoch = collections.Counter()
    total = 0
    for row in open(prof):
        e, a, n, c = row.split()
        e, w = int(e), int(n) * int(c)
        per_epoch[e] += w
        if want is not None and e not in want:
            continue
        a = int(a, 16) & ~1
        total += w
        i = bisect.bisect_right(starts, a) - 1
        inside = i >= 0 and a < syms[i][0] + max(syms[i][1], 1)
        per_fn[syms[i][2] if inside else "?%x" % a] += w
    if want is None:
        print("epochs (instructions, the line that ended each):")
        for e in sorted(per_epoch):
            if per_epoch[e] > 10_000:
                print("  %4d %13d  %s" % (e, per_epoch[e], lines[e] if e < len(lines) else "(exit)"))
    print("total %d instructions" % total)
    for name, w in per_fn.most_common(top):
        print("%13d %5.1f%%  %s" % (w, 100.0 * w / max(total, 1), name[:150]))


if __name__ == "__main__":
    main()
