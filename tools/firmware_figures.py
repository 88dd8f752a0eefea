#!/usr/bin/env python3
"""Regenerate (or check) the flash and SRAM figures of docs/firmware.md from the firmware build.

Usage: python3 tools/firmware_figures.py [--check] [--no-build] [--doc docs/firmware.md]

Builds `firmware-sim/board-mps2` (release, both binaries; CARGO_TARGET_DIR/board-mps2 or
target/board-mps2, as tests/src/qemu.rs) through the canonical source path CANON (below), reads
each ELF's linker symbols the way the firmware's own report does (`src/measure.rs`: flash =
`__erodata` + `.data`, static RAM = `__euninit` − `__sdata`, stack room = `_stack_start` −
`_stack_end`, PSRAM = `__epsram` − `__spsram`), and rewrites the figures of docs/firmware.md that
follow from them: flash, static RAM, stack room, the section sizes, PSRAM, and the peaks (static
RAM + the stack high-water marks the doc states, which only a QEMU run measures). With `--check`
it changes nothing and exits 1 if the doc differs in any figure (CI). Standard library only (the ELF is parsed here).
"""

import argparse
import fcntl
import os
import re
import struct
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
BOARD = REPO / "firmware-sim" / "board-mps2"
TARGET = "thumbv7em-none-eabihf"
GOLDEN, HEAD = "fringe3d-board-mps2", "fringe3d-board-mps2-head"
RAM = 256 * 1024


def elf_layout(path):
    """Section sizes by name and symbol values by name of a 32-bit little-endian ELF."""
    b = Path(path).read_bytes()
    if b[:4] != b"\x7fELF" or b[4] != 1 or b[5] != 1:
        sys.exit(f"{path}: not a 32-bit little-endian ELF")
    shoff, = struct.unpack_from("<I", b, 0x20)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", b, 0x2E)
    secs = [struct.unpack_from("<IIIIIIIIII", b, shoff + i * shentsize) for i in range(shnum)]
    strtab_off = secs[shstrndx][4]

    def cstr(off):
        return b[off:b.index(b"\0", off)].decode()

    sections = {cstr(strtab_off + s[0]): s for s in secs}
    sizes = {name: s[5] for name, s in sections.items()}
    symbols = {}
    symtab = sections.get(".symtab")
    if symtab:
        names = secs[symtab[6]][4]  # sh_link: the symbol string table
        for off in range(symtab[4], symtab[4] + symtab[5], 16):
            name, value = struct.unpack_from("<II", b, off)
            if name:
                symbols[cstr(names + name)] = value
    return sizes, symbols


def figures(path):
    sizes, sym = elf_layout(path)
    data = sym["__edata"] - sym["__sdata"]
    f = {
        "flash": sym["__erodata"] + data,
        "static": sym["__euninit"] - sym["__sdata"],
        "room": sym["_stack_start"] - sym["_stack_end"],
        "vector_table": sizes.get(".vector_table", 0),
        "text": sizes.get(".text", 0),
        "rodata": sizes.get(".rodata", 0),
        "data": data,
    }
    if "__spsram" in sym:
        f["psram"] = sym["__epsram"] - sym["__spsram"]
    return f


def num(n):
    """263248 -> '263 248' (the docs' thousands separator)."""
    return f"{n:,}".replace(",", " ")


def kib(n):
    return f"{n / 1024:.1f}"


def parse_num(s):
    return int(s.replace(" ", "").replace("≈", ""))


# Where the firmware is built from: a symbolic link to the checkout at one path on every machine.
# cargo hashes the absolute path of every crate outside the board's own workspace (the core, the
# head) into the symbol names, and those names order what LLVM optimises and how the linker lays
# out the code: built from the checkout's own path, the flash moved by 4 to 1 056 bytes between
# checkouts of one commit. Built from CANON (with the paths the panic locations and debug lines
# name remapped below), the flash image is the same byte for byte on any checkout path; the QEMU
# tests (tests/src/qemu.rs, `CANON`) build the same way and share this build. LOCK serialises the
# link's re-pointing and the build between checkouts on one machine.
CANON = Path("/tmp/fringe3d-firmware-src")
LOCK = Path("/tmp/fringe3d-firmware-src.lock")


def point_canon():
    """Point CANON at this checkout (atomically: a new link renamed over the old one)."""
    if CANON.is_symlink() and Path(os.readlink(CANON)) == REPO:
        return
    tmp = CANON.with_name(f"{CANON.name}.{os.getpid()}")
    try:
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(REPO, target_is_directory=True)
        os.replace(tmp, CANON)
    except OSError as e:
        sys.exit(f"firmware_figures: cannot point {CANON} at {REPO}: {e}")


def path_independent_config():
    """The `--config` that makes the firmware's bytes independent of where the checkout and the
    cargo home are: the panic locations in `.rodata` and the debug lines name source files, by
    CANON's path for the crates the build reaches through it, by the real path for the working
    directory, and under the cargo home for registry crates. Remapped to `/fringe3d` and `/cargo`,
    the flash figures reproduce on any machine. The same flags as `path_independent_config` in
    tests/src/qemu.rs (the QEMU tests build the same binaries)."""
    cargo_home = os.environ.get("CARGO_HOME") or str(Path.home() / ".cargo")
    flags = [f"--remap-path-prefix={CANON}=/fringe3d", f"--remap-path-prefix={REPO}=/fringe3d",
             f"--remap-path-prefix={cargo_home}=/cargo"]
    quoted = ", ".join('"' + f.replace("\\", "\\\\").replace('"', '\\"') + '"' for f in flags)
    return f"target.{TARGET}.rustflags=[{quoted}]"


def build():
    target_dir = Path(os.environ["CARGO_TARGET_DIR"]) / "board-mps2" if os.environ.get(
        "CARGO_TARGET_DIR") else REPO / "target" / "board-mps2"
    env = dict(os.environ, CARGO_TARGET_DIR=str(target_dir))
    for k in ("RUSTFLAGS", "CARGO_ENCODED_RUSTFLAGS", "CARGO_BUILD_TARGET"):
        env.pop(k, None)
    board = CANON / BOARD.relative_to(REPO)
    with open(LOCK, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        point_canon()
        r = subprocess.run(["cargo", "build", "--release", "--quiet", "--target", TARGET,
                            "--manifest-path", str(board / "Cargo.toml"),
                            "--config", path_independent_config()],
                           cwd=board, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"firmware_figures: the board firmware does not build:\n{r.stderr}")
    return target_dir / TARGET / "release"


NUM = r"(?:≈ )?\d{1,3}(?: \d{3})*"


def section(doc, start, end):
    """(offset, text) of the part of `doc` from the line containing `start` up to `end`."""
    i = doc.index(start)
    j = doc.index(end, i)
    return i, doc[i:j]


def update(doc, g, h):
    """The doc with every build-derived figure replaced; raises if a row is missing."""
    # The golden-vector binary's measurement table and budget.
    i, part = section(doc, "## Measurements", "## The head on QEMU")
    stack_setup = parse_num(re.search(rf"\| stack high-water, set-up \| ({NUM}) \|", part)[1])
    stack_scan = parse_num(re.search(rf"\| stack high-water, scan \| ({NUM}) \|", part)[1])
    peak, peak_scan = g["static"] + stack_setup, g["static"] + stack_scan
    subs = [
        (rf"(\| flash \| ){NUM}( \|)", rf"\g<1>{num(g['flash'])}\g<2>"),
        (rf"(`llvm-size -A` gives ){NUM} \+ {NUM} \+ {NUM} \+ {NUM}",
         rf"\g<1>{num(g['vector_table'])} + {num(g['text'])} + {num(g['rodata'])} + "
         rf"{num(g['data'])}"),
        (rf"(\| static RAM \| ){NUM} \(\d+\.\d KiB\)",
         rf"\g<1>{num(g['static'])} ({kib(g['static'])} KiB)"),
        (rf"(\| stack room \| ){NUM}( \|)", rf"\g<1>{num(g['room'])}\g<2>"),
        (rf"(\| \*\*peak total\*\* \| \*\*){NUM} \(\d+\.\d KiB\)\*\*",
         rf"\g<1>{num(peak)} ({kib(peak)} KiB)**"),
        (rf"(static \+ set-up stack; ){NUM} \(\d+\.\d KiB\)( during the scan)",
         rf"\g<1>{num(peak_scan)} ({kib(peak_scan)} KiB)\g<2>"),
        (rf"(\| \*\*total\*\* \| .*? \| \*\*){NUM}(\*\* \|)", rf"\g<1>{num(g['static'])}\g<2>"),
        (r"\*\*\d+\.\d KiB at the peak — it fits in 256 KiB, with \d+\.\d KiB to spare\*\*",
         f"**{kib(peak)} KiB at the peak — it fits in 256 KiB, with {kib(RAM - peak)} KiB to "
         "spare**"),
    ]
    doc = doc[:i] + apply(part, subs, "Measurements") + doc[i + len(part):]

    # The head binary's table.
    i, part = section(doc, "Figures (release build; printed by the firmware", "**The test**")
    stack = parse_num(re.search(rf"\| stack high-water, after a scan \| ({NUM})(?= \(| \|)", part)[1])
    peak = h["static"] + stack
    subs = [
        (rf"(\| flash \| ){NUM}( \|)", rf"\g<1>{num(h['flash'])}\g<2>"),
        (rf"(\| static SRAM \| ){NUM}( )", rf"\g<1>{num(h['static'])}\g<2>"),
        (rf"(\| \*\*SRAM peak\*\* \| \*\*){NUM} \(\d+\.\d KiB of 256 KiB\)\*\*",
         rf"\g<1>{num(peak)} ({kib(peak)} KiB of 256 KiB)**"),
        (rf"(\| PSRAM \| ){NUM}( )", rf"\g<1>{num(h['psram'])}\g<2>"),
    ]
    return doc[:i] + apply(part, subs, "head figures") + doc[i + len(part):]


def apply(text, subs, where):
    for pattern, repl in subs:
        text, n = re.subn(pattern, repl, text, count=1)
        if n != 1:
            sys.exit(f"firmware_figures: docs/firmware.md ({where}) has no row matching {pattern!r}")
    return text


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if the doc differs; write nothing")
    ap.add_argument("--no-build", action="store_true", help="use the existing release build")
    ap.add_argument("--doc", default=str(REPO / "docs" / "firmware.md"))
    args = ap.parse_args()
    if args.no_build:
        d = os.environ.get("CARGO_TARGET_DIR")
        out = (Path(d) / "board-mps2" if d else REPO / "target" / "board-mps2") / TARGET / "release"
    else:
        out = build()
    g, h = figures(out / GOLDEN), figures(out / HEAD)
    doc = Path(args.doc).read_text(encoding="utf-8")
    print(f"golden-vector binary: flash {num(g['flash'])}, static RAM {num(g['static'])}, "
          f"stack room {num(g['room'])}")
    print(f"head binary: flash {num(h['flash'])}, static SRAM {num(h['static'])}, "
          f"PSRAM {num(h.get('psram', 0))}")
    new = update(doc, g, h)
    if new == doc:
        print("docs/firmware.md: figures up to date")
        return 0
    if args.check:
        import difflib
        sys.stdout.writelines(difflib.unified_diff(
            doc.splitlines(True), new.splitlines(True), "docs/firmware.md", "from the build"))
        print("docs/firmware.md: figures differ from the build "
              "(run python3 tools/firmware_figures.py to update them)")
        return 1
    Path(args.doc).write_text(new, encoding="utf-8")
    print("docs/firmware.md: figures updated")
    return 0


if __name__ == "__main__":
    sys.exit(main())
