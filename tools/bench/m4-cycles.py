#!/usr/bin/env python3
"""m4-cycles: a Cortex-M4 cycle estimate from the instructions the image really executes.

Usage: m4-cycles.py TRACE [--ws N] [--no-art] [--nm NM.txt]

TRACE is a QEMU log of `-d in_asm,exec,nochain` (every translated block's instructions once, then one
line per execution of a block), usually limited to the code of interest with -dfilter, e.g.

    qemu-system-arm -M netduinoplus2 -nographic -icount shift=0 -serial file:serial.log \\
        -d in_asm,exec,nochain -dfilter 0x0800dd78+0x327c -D trace.log -kernel swell-fw-selftest.elf

(-dfilter takes the address and size of the function, from `arm-none-eabi-nm -S`).
Prints the executed instructions, the estimated cycles and cycles per instruction, by class; with
--nm (the output of `arm-none-eabi-nm -S` of the image) also by function.

The model (written down in docs/stm32f405.md, "A cycle model"):
  core, Cortex-M4 TRM (r0p1), "Processor instruction timings":
    data processing, shifts, moves, compares, SSAT/USAT, bit fields, IT, NOP      1
    MUL, SMULL/UMULL, SMLAL/UMLAL, SMMUL, SMMLA(R), SMLA*/SMUL*                   1
    MLA, MLS                                                                       2
    SDIV, UDIV                                                                     12 (worst case)
    LDR/STR of one register                    2, or 1 right after another load or store (pipelined)
    LDRD/STRD                                                                      3
    LDM/STM/PUSH/POP of N registers                                                1 + N
    branch not taken 1; taken (a block that does not fall through)               1 + 3 refill
  flash, RM0090 (168 MHz: 5 wait states) and its ART accelerator: the instruction cache holds
  64 lines of 128 bits, modelled fully associative with LRU replacement; a line that hits costs
  nothing; a miss after a taken branch costs the 5 wait states + 1; a miss in straight-line code is
  hidden by the prefetch buffer as far as the previous line's execution took 6 cycles or more, and
  costs the rest.
Exit: 0 done, 1 the trace cannot be read or holds no execution, 2 bad arguments.
"""
import re
import sys
from collections import OrderedDict

LINE = 16  # bytes in an ART cache line (128 bits)


def usage(msg=None):
    if msg:
        print("m4-cycles: " + msg, file=sys.stderr)
        sys.exit(2)
    print(__doc__.strip())
    sys.exit(0)


def klass(mnem, ops):
    """Class and base cycles of one instruction (without pipelining, branches and fetch)."""
    m = mnem.split(".")[0]
    base = re.sub(r"(eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le|al)$", "", m)
    if m in ("udiv", "sdiv"):
        return "div", 12
    if m in ("mla", "mls"):
        return "mul", 2
    if re.match(r"^(mul|muls|smull|umull|smlal|umlal|smmul|smmulr|smmla|smmlar|smmls|smmlsr|"
                r"smla[bt][bt]|smlaw[bt]|smul[bt][bt]|smulw[bt]|smuad|smusd|smlad|smlsd)$", m):
        return "mul", 1
    if re.match(r"^(push|pop|ldm|stm|ldmia|stmia|ldmdb|stmdb)", m):
        n = len(re.findall(r"r\d+|sb|sl|fp|ip|lr|pc|sp", ops.split("{", 1)[-1])) if "{" in ops else 1
        return "ldm/stm", 1 + n
    if re.match(r"^(ldrd|strd)", m):
        return "ldrd/strd", 3
    if re.match(r"^(ldr|str)", m):
        return "load/store", 2
    if re.match(r"^(b|bl|blx|bx|cbz|cbnz|tbb|tbh)$", base):
        return "branch", 1
    return "alu", 1


def main(argv):
    if len(argv) < 2 or argv[1] in ("-h", "--help"):
        usage()
    if argv[1].startswith("-"):
        usage("unknown argument '%s' (see --help)" % argv[1])
    path, ws, art, nm = argv[1], 5, True, None
    args = argv[2:]
    while args:
        a = args.pop(0)
        if a == "--ws" and args:
            try:
                ws = int(args.pop(0))
            except ValueError:
                usage("--ws wants a whole number of wait states")
        elif a == "--no-art":
            art = False
        elif a == "--nm" and args:
            nm = args.pop(0)
        else:
            usage("unknown argument '%s' (see --help)" % a)
    try:
        f = open(path)
    except OSError as e:
        print("m4-cycles: %s" % e, file=sys.stderr)
        return 1
    blocks = {}  # start pc -> list of (pc, size, mnemonic, operands)
    cur = None
    execs = []
    ins = re.compile(r"^0x([0-9a-f]+):\s+([0-9a-f]{4})(?: ([0-9a-f]{4}))?\s+(\S+)\s*(.*)$")
    ex = re.compile(r"^Trace \d+: \S+ \[[0-9a-f]+/([0-9a-f]+)/")
    with f:
        for line in f:
            if line.startswith("IN:"):
                cur = []
                continue
            m = ins.match(line)
            if m and cur is not None:
                pc = int(m.group(1), 16)
                if not cur:
                    blocks[pc] = cur
                cur.append((pc, 4 if m.group(3) else 2, m.group(4), m.group(5)))
                continue
            m = ex.match(line)
            if m:
                cur = None
                execs.append(int(m.group(1), 16))
    execs = [pc for pc in execs if pc in blocks]
    if not execs:
        print("m4-cycles: no executed block in %s (run QEMU with -d in_asm,exec,nochain)" % path,
              file=sys.stderr)
        return 1
    syms = []  # (start, end, name) of the functions, for the split by function
    if nm:
        try:
            with open(nm) as g:
                for line in g:
                    p = line.split()
                    if len(p) == 4 and p[2] in "tTwW":
                        a = int(p[0], 16) & ~1
                        syms.append((a, a + int(p[1], 16), p[3]))
        except (OSError, ValueError) as e:
            print("m4-cycles: %s: %s" % (nm, e), file=sys.stderr)
            return 1
        syms.sort()
    fn_of = {}

    def function(pc):
        if pc not in fn_of:
            lo, hi = 0, len(syms)
            while lo < hi:
                mid = (lo + hi) // 2
                if syms[mid][0] <= pc:
                    lo = mid + 1
                else:
                    hi = mid
            fn_of[pc] = syms[lo - 1][2] if lo and pc < syms[lo - 1][1] else "?"
        return fn_of[pc]

    by_fn = {}
    cache = OrderedDict()
    by = {}
    total_i = total_c = fetch_c = branch_c = 0
    prev_ls = False
    prev_end = None
    line_cycles = 6  # cycles spent on the previous line (straight-line prefetch)
    cur_line = None
    for k, start in enumerate(execs):
        blk = blocks[start]
        taken_in = prev_end is not None and start != prev_end
        for idx, (pc, size, mnem, ops) in enumerate(blk):
            cl, c = klass(mnem, ops)
            if cl == "load/store" and prev_ls:
                c = 1
            prev_ls = cl in ("load/store", "ldrd/strd")
            # instruction fetch through the ART
            ln = pc // LINE
            if ln != cur_line:
                pen = 0
                if not art:
                    pen = ws if (taken_in and idx == 0) else max(0, ws + 1 - line_cycles)
                elif ln in cache:
                    cache.move_to_end(ln)
                else:
                    pen = ws + 1 if (taken_in and idx == 0) else max(0, ws + 1 - line_cycles)
                    cache[ln] = True
                    if len(cache) > 64:
                        cache.popitem(last=False)
                fetch_c += pen
                c += pen
                cur_line = ln
                line_cycles = 0
            line_cycles += c
            e = by.setdefault(cl, [0, 0])
            e[0] += 1
            e[1] += c
            total_i += 1
            total_c += c
            if syms:
                e = by_fn.setdefault(function(start), [0, 0])
                e[0] += 1
                e[1] += c
        last_pc, last_size = blk[-1][0], blk[-1][1]
        prev_end = last_pc + last_size
        # the block's last instruction is a branch: taken when the next block does not follow on
        if k + 1 < len(execs) and execs[k + 1] != prev_end:
            total_c += 3
            branch_c += 3
            by.setdefault("branch", [0, 0])[1] += 3
            if syms:
                by_fn[function(start)][1] += 3
    print("executed: %d instructions in %d blocks (%d distinct)" % (total_i, len(execs), len(blocks)))
    print("model: Cortex-M4 timings, flash %d wait states, ART cache %s" % (ws, "on (64 x 128 bit, LRU)" if art else "off"))
    for cl in sorted(by, key=lambda x: -by[x][1]):
        n, c = by[cl]
        print("  %-11s %10d instructions %10d cycles" % (cl, n, c))
    print("  (of which flash stalls %d cycles, taken-branch refills %d cycles)" % (fetch_c, branch_c))
    print("cycles: %d, %.3f cycles per instruction" % (total_c, total_c / total_i))
    for fn in sorted(by_fn, key=lambda x: -by_fn[x][1]):
        n, c = by_fn[fn]
        print("  function %-34s %9d instructions %9d cycles %6.3f per instruction" % (fn, n, c, c / n))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
