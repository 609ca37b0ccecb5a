"""Where Dendry's per-pixel kernel spends its work on the CPU, by function and line or in instructions.

It gives the share of the time per Warp function and per Python line, or the instructions per
pixel of one or more checkouts.

    python scripts/profile_dendry.py                                  # Table 1 setup, exact search, elevation
    python scripts/profile_dendry.py --search paper --output distance --top 40
    python scripts/profile_dendry.py --count /tmp/before .            # instructions per pixel, two checkouts

Warp compiles a module's kernels into one object and loads it without symbols, and at the
default inlining thresholds the per-pixel kernel becomes one function of about 60 KB, so a
sampling profiler only sees anonymous addresses. The default mode compiles the per-pixel
module with Warp's default CPU flags plus line tables (the same machine code: checked on the
Table 1 kernel, whose disassembly is identical), samples a window under Linux ``perf``, maps each sample into the object
through the kernel's entry address, and names it with ``addr2line``: the share of samples
under each Warp function (inclusive, along the chain of inlined calls) and the hottest
lines, each given by its function and the line of the Python source that Warp's generated
code cites (``<L n>``). Needs ``perf``, ``objdump`` and ``addr2line``. Where LLVM merged
identical code, ``addr2line`` names one of its sources: a single-octave Perlin control's
samples land partly under ``ridged`` and ``fbm``. For time per stage, see ``stages_dendry.py``.

On a shared machine timings of the same code can move by 1.2-1.4x from minute to minute
(see ``ab_dendry.py``), which hides changes of a few per cent. ``--count`` measures work
instead of time: it runs each checkout's per-pixel window under ``valgrind --tool=callgrind``,
counting the instructions executed inside Warp launches, and reports instructions per pixel
(a 1-pixel window is subtracted), reproducible to a few instructions. Instructions are not
time (latency, cache misses and branch mispredictions count for nothing), so confirm a gain
with ``ab_dendry.py``; valgrind runs kernels compiled for the CPU it emulates. Needs valgrind.
(A change that cut 7 % of the paper search's instructions gained 1-3 % of its time.)
``--count-lines`` joins the two: the instructions of one checkout's window (callgrind, one
count per instruction address) attributed by function and line as in the default mode, with
the amount per pixel.

    python scripts/profile_dendry.py --count-lines --window 32 --top 60
"""

from __future__ import annotations

import argparse
import collections
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

SCRIPTS = Path(__file__).resolve().parent
sys.path.insert(0, str(SCRIPTS))
from ab_dendry import _case, _is_checkout, _load  # noqa: E402  (the same workloads as the A/B timings)

LINE_TABLES = " -debug-info-kind=line-tables-only -dwarf-version=4"


def _child(args) -> None:
    """Run the window (inside perf or valgrind); write what the parent needs to ``args.report``."""
    import ctypes

    import numpy as np
    import warp as wp

    wp.config.quiet = True
    if args.line_tables:
        flags = wp.config.cpu_compiler_flags
        wp.config.cpu_compiler_flags = ("-march=native" if flags is None else flags) + LINE_TABLES
    from warp._src import context as wctx

    entries = {}
    hooks = wctx.ModuleExec.get_kernel_hooks

    def recording(self, kernel):
        h = hooks(self, kernel)
        if h.forward is not None:
            name = self.get_kernel_mangled_name(kernel) + "_cpu_forward"
            entries[name] = (ctypes.cast(h.forward, ctypes.c_void_p).value, kernel.module.name)
        return h

    wctx.ModuleExec.get_kernel_hooks = recording
    with tempfile.TemporaryDirectory() as tmp:
        sys.path.insert(0, tmp)
        dmod, cmod = _load(Path(args.root).resolve(), args.package, Path(tmp))
        kw, size = _case(dmod, cmod, args.workload, args.search, args.levels)
        w = min(args.window, size)
        window = ((size - w) // 2, (size - w) // 2, w, w)
        image = dmod.dendry((size, size), window=window, output=args.output, mode="pixel", **kw)
        for _ in range(args.runs):
            image = dmod.dendry((size, size), window=window, output=args.output, mode="pixel", **kw)
        objects = {}
        for name, (_, module_name) in entries.items():
            module = wp.get_module(module_name)
            found = []
            for _, block_dim in module.execs:  # (the CPU launches blocks of 1 thread)
                folder = Path(wp.config.kernel_cache_dir) / module.get_module_identifier(block_dim)
                found += folder.glob("*.o")
            found.sort(key=lambda p: p.stat().st_mtime)  # the newest: compiled for this CPU
            objects[name] = str(found[-1]) if found else ""
    report = {"entries": {k: v[0] for k, v in entries.items()}, "objects": objects,
              "checksum": float(np.nansum(image.astype(np.float64))), "pixels": int(image.size)}
    Path(args.report).write_text(json.dumps(report))


def _child_command(args, root: str, package: str, window: int, runs: int, report: Path, line_tables: bool):
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--root", root, "--package", package,
           "--window", str(window), "--runs", str(runs), "--report", str(report), "--workload", args.workload,
           "--search", args.search, "--output", args.output] + (["--levels", str(args.levels)] if args.levels else [])
    return cmd + (["--line-tables"] if line_tables else [])


def _symbols(obj: str) -> list[tuple[int, int, str]]:
    """(offset, size, name) of the functions an object defines."""
    out = subprocess.run(["objdump", "-t", obj], capture_output=True, text=True, check=True).stdout
    rows = []
    for line in out.splitlines():
        if " F " in line:
            parts = line.split()
            rows.append((int(parts[0], 16), int(parts[4], 16), parts[-1]))
    return rows


def _need(mode: str, *tools: str) -> None:
    """Exit with a clear message when a tool ``mode`` runs is not installed."""
    for tool in tools:
        if shutil.which(tool) is None:
            sys.exit(f"profile_dendry: '{tool}' is not installed ({mode} needs {', '.join(tools)})")


def _profile(args) -> None:
    _need("the default mode", "perf", "objdump", "addr2line")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        report, data = tmp / "report.json", tmp / "perf.data"
        # compile first (outside perf), then sample the runs
        subprocess.run(_child_command(args, args.root, "wd_p", 8, 0, report, True), check=True,
                       stdout=subprocess.DEVNULL)
        rec = ["perf", "record", "-q", "-F", str(args.frequency), "-o", str(data)]
        subprocess.run(rec + _child_command(args, args.root, "wd_p", args.window, args.runs, report, True), check=True,
                       stdout=subprocess.DEVNULL)
        info = json.loads(report.read_text())
        ips = subprocess.run(["perf", "script", "-i", str(data), "-F", "ip"], capture_output=True, text=True,
                             check=True).stdout.split()
    weights: collections.Counter[int] = collections.Counter(int(ip, 16) for ip in ips)
    _attribute(args, info, weights, f"{args.window}^2 window x {args.runs}: {len(ips)} samples")


def _grind_weights(out: Path) -> collections.Counter[int]:
    """Instructions executed at each address, from a callgrind output written with
    ``--dump-instr=yes --compress-pos=no`` (every cost line starts with its address): the self
    cost of each instruction; the inclusive costs of calls, on the line after each ``calls=``,
    are left out."""
    weights: collections.Counter[int] = collections.Counter()
    skip, npos = False, 1
    for line in out.read_text().splitlines():
        if line.startswith("positions:"):
            npos = len(line.split()) - 1  # e.g. "positions: instr line": the cost is the third field
        elif line.startswith("calls="):
            skip = True
        elif line.startswith("0x"):
            if not skip:
                fields = line.split()
                weights[int(fields[0], 16)] += int(fields[npos]) if len(fields) > npos else 0
            skip = False
    return weights


def _count_lines(args) -> None:
    """Instructions by function and line (callgrind on the line-table build, as ``--count``)."""
    _need("--count-lines", "valgrind", "objdump", "addr2line")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        report, out = tmp / "report.json", tmp / "callgrind.out"
        subprocess.run(["valgrind", "--tool=none"] + _child_command(args, args.root, "wd_p", 1, 0, report, True),
                       check=True, capture_output=True)
        grind = ["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=ffi_call*",
                 "--dump-instr=yes", "--compress-pos=no", f"--callgrind-out-file={out}"]
        subprocess.run(grind + _child_command(args, args.root, "wd_p", args.window, 0, report, True), check=True,
                       capture_output=True)
        info = json.loads(report.read_text())
        weights = _grind_weights(out)
    per = 1.0 / info["pixels"]
    _attribute(args, info, weights, f"{args.window}^2 window: instructions", per)


def _attribute(args, info: dict, weights: collections.Counter[int], what: str, per: float = 0.0) -> None:
    """Print the share of ``weights`` (address -> samples or instructions) inside the per-pixel
    image kernel by Warp function and by Python line (``per`` > 0: also the amount per pixel)."""
    counts: collections.Counter[int] = collections.Counter()
    obj = None
    for name, entry in info["entries"].items():
        if "image_kernel" not in name or not info["objects"].get(name):
            continue
        obj = info["objects"][name]
        syms = _symbols(obj)
        start = [s for s in syms if s[2] == name][0][0]
        end = max(o + n for o, n, _ in syms)
        base = entry - start
        for ip, n in weights.items():
            off = ip - base
            if 0 <= off < end:
                counts[off] += n
    if obj is None:
        sys.exit("profile_dendry: the per-pixel image kernel was not found among the launches")
    total = sum(weights.values())
    inside = sum(counts.values())
    offsets = sorted(counts)
    lines = []
    for i in range(0, len(offsets), 2000):  # (command lines of bounded length)
        lines += subprocess.run(["addr2line", "-a", "-i", "-f", "-e", obj] + [hex(o) for o in offsets[i:i + 2000]],
                                capture_output=True, text=True, check=True).stdout.splitlines()
    # the Python line each line of the generated code belongs to: Warp writes a comment citing it
    # (``// statement <L n>``) before the code of each statement
    cites, last = [], "?"
    for text in Path(obj.rsplit(".", 2)[0] + ".cpp").read_text().splitlines():
        found = re.search(r"<L (\d+)>\s*$", text)
        last = found.group(1) if found else ("?" if text.startswith("}") else last)
        cites.append(last)
    frames: dict[int, list[tuple[str, int]]] = {}
    at, i = None, 0
    while i < len(lines):
        if lines[i].startswith("0x"):
            at = int(lines[i], 16)
            frames[at] = []
            i += 1
            continue
        fn, loc = lines[i], lines[i + 1]
        i += 2
        m = re.match(r".*\.cpp:(\d+)", loc)
        if m:  # a frame in the module's generated code (not Warp's headers)
            frames[at].append((re.sub(r"_\d+$", "", re.sub(r"^_ZL\d+", "", fn).split("_0", 1)[0]), int(m.group(1))))
    inclusive: collections.Counter[str] = collections.Counter()
    by_line: collections.Counter[tuple[str, str]] = collections.Counter()
    for off, n in counts.items():
        chain = frames.get(off, [])
        for fn in {f for f, _ in chain}:
            inclusive[fn] += n
        if chain:
            fn, ln = chain[0]
            by_line[(fn, cites[ln - 1] if 0 < ln <= len(cites) else "?")] += n

    def amount(n: int) -> str:
        return f"{100 * n / inside:5.1f} %" + (f" {n * per:9,.0f}" if per > 0 else "")

    print(f"{args.workload} {args.search} {args.output}, {what}: {total}, "
          f"{inside} ({100 * inside / max(total, 1):.0f} %) in the per-pixel kernel"
          + (f", {inside * per:,.0f} per pixel" if per > 0 else ""))
    print("\ninclusive share by Warp function (along the chain of inlined calls)"
          + (", and per pixel:" if per > 0 else ":"))
    for fn, n in inclusive.most_common(args.top):
        print(f"  {amount(n)}  {fn}")
    # the file defining each function, to quote its lines
    files = {}
    for path in sorted((Path(args.root) / "kernels").glob("*.py")):
        text = path.read_text().splitlines()
        for line in text:
            found = re.match(r"def (\w+)\(", line)
            if found:
                files.setdefault(found.group(1), (path.name, text))
    print("\nhottest lines (the innermost function of the module at each sample, and its Python line):")
    for (fn, ln), n in by_line.most_common(args.top):
        name, text = files.get(fn, ("?", []))
        quote = text[int(ln) - 1].strip() if ln.isdigit() and int(ln) <= len(text) else ""
        print(f"  {amount(n)}  {name}:{ln} ({fn})  {quote[:90]}")


def _count(args) -> None:
    _need("--count", "valgrind")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for i, root in enumerate(args.count):
            package = f"wd_c{i}"
            report = tmp / f"{package}.json"
            grind = ["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=ffi_call*",
                     f"--callgrind-out-file={tmp / 'callgrind.out'}"]
            # the first run compiles the kernels for valgrind's CPU (uncounted, and quicker without
            # callgrind's instrumentation: a compile runs inside a launch)
            subprocess.run(["valgrind", "--tool=none"] + _child_command(args, root, package, 1, 0, report, False),
                           check=True, capture_output=True)
            collected = []
            for window in (1, args.window):
                run = subprocess.run(grind + _child_command(args, root, package, window, 0, report, False),
                                     check=True, capture_output=True, text=True)
                found = re.search(r"Collected : ([\d,]+)", run.stderr)
                if found is None:
                    sys.exit(f"profile_dendry: no instruction count in valgrind's output:\n{run.stderr[-2000:]}")
                collected.append(int(found.group(1).replace(",", "")))
            per = (collected[1] - collected[0]) / (args.window**2 - 1)
            checksum = json.loads(report.read_text())["checksum"]
            levels = f" {args.levels} levels" if args.levels else ""
            print(f"{root}: {per:,.0f} instructions per pixel ({args.workload}{levels} {args.search} {args.output}, "
                  f"{args.window}^2 window; checksum {checksum!r})", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workload", choices=["table1", "lichtenberg"], default="table1",
                    help="the paper's Table 1 setup (512^2, 2 levels) or the 1024^2 Lichtenberg figure (6 levels)")
    ap.add_argument("--search", choices=["exact", "paper"], default="exact")
    ap.add_argument("--levels", type=int, choices=range(1, 7), metavar="1..6",
                    help="levels instead of the workload's own (Table 1: 2, Lichtenberg: 6)")
    ap.add_argument("--output", choices=["distance", "elevation", "level"], default="elevation")
    ap.add_argument("--window", type=int, default=None,
                    help="side of the centred window (default: 160 to profile, 64 to count)")
    ap.add_argument("--runs", type=int, default=20, help="runs sampled by the profile")
    ap.add_argument("--root", default=str(SCRIPTS.parent), help="checkout to profile (default: this one)")
    ap.add_argument("--frequency", type=int, default=4000, help="perf samples per second")
    ap.add_argument("--top", type=int, default=30, help="rows of each table")
    ap.add_argument("--count", nargs="+", metavar="ROOT", help="count instructions per pixel of these checkouts")
    ap.add_argument("--count-lines", action="store_true",
                    help="instructions (callgrind) instead of time samples by function and line, per pixel")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--package", default="wd_p", help=argparse.SUPPRESS)
    ap.add_argument("--report", help=argparse.SUPPRESS)
    ap.add_argument("--line-tables", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.workload == "lichtenberg" and args.output == "elevation":
        ap.error("the Lichtenberg figure has no elevation: use --output distance or level")
    if args.window is None:
        args.window = 64 if args.count or args.count_lines else 160
    if not args.child and (args.window < 2 or args.runs < 0 or args.frequency < 1 or args.top < 1):
        ap.error(f"--window must be at least 2 and --runs, --frequency, --top positive, got "
                 f"{args.window}, {args.runs}, {args.frequency}, {args.top}")
    for root in args.count or [args.root]:
        if not _is_checkout(root):
            ap.error(f"{root!r} is not a wdendrite checkout (no wdendrite/ and kernels/ in it)")
    if args.child:
        _child(args)
    elif args.count:
        _count(args)
    elif args.count_lines:
        _count_lines(args)
    else:
        _profile(args)


if __name__ == "__main__":
    main()
