#!/usr/bin/env python3
"""No panic path in the head: check the example's release build for calls to the panic machinery.

Usage: python3 examples/head-minimal/check_no_panic.py [--no-build] [-v]

Builds `examples/head-minimal` (release, thumbv7em-none-eabihf; CARGO_TARGET_DIR/head-minimal
or target/head-minimal), disassembles it with llvm-objdump, and lists every call to a panic
entry point (`core::panicking::*`, slice-index and length-mismatch failures, `unwrap_failed`, ...)
with the source line it was inlined from (llvm-addr2line -i). Each site is attributed to the
innermost frame in this repository.

Exits 1 if a site lies anywhere but in ALLOWED (files whose sites are known and reported in
docs/integration.md, "No panics"); prints the allowed ones as a notice. When no site is left, it
also builds with `--features no-panic` (a panic handler that calls an undefined symbol) and
requires that build to link: the linker's proof that no panic path survives.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
TARGET = "thumbv7em-none-eabihf"
BIN = "fringe3d-head-minimal"

# Files with known panic sites that this check tolerates until they are fixed (issue #23 item 5).
# None since 2026-12-02: the last (core/src/wire/desc.rs, the description's level slice) is gone,
# and the `no-panic` build links; any site now fails the check.
ALLOWED: set = set()

PANIC_SYMBOL = re.compile(
    r"core::panicking::|core::slice::index::|slice_index_fail|len_mismatch_fail|"
    r"core::option::unwrap_failed|core::result::unwrap_failed|core::option::expect_failed|"
    r"core::str::slice_error_fail|panic_const|rust_begin_unwind"
)


def tool(name):
    """llvm-objdump / llvm-addr2line: plain or versioned (llvm-objdump-16), on PATH."""
    if shutil.which(name):
        return name
    for d in os.environ.get("PATH", "").split(os.pathsep):
        if os.path.isdir(d):
            for f in sorted(os.listdir(d), reverse=True):
                if re.fullmatch(re.escape(name) + r"-\d+", f):
                    return os.path.join(d, f)
    sys.exit(f"check_no_panic: {name} not found (Debian: apt-get install llvm)")


def target_dir():
    d = os.environ.get("CARGO_TARGET_DIR")
    return Path(d) / "head-minimal" if d else REPO / "target" / "head-minimal"


def build(features=None):
    cmd = ["cargo", "build", "--release", "--target", TARGET, "--quiet"]
    if features:
        cmd += ["--features", features]
    env = dict(os.environ, CARGO_TARGET_DIR=str(target_dir()))
    for k in ("RUSTFLAGS", "CARGO_ENCODED_RUSTFLAGS", "CARGO_BUILD_TARGET"):
        env.pop(k, None)
    return subprocess.run(cmd, cwd=HERE, env=env, capture_output=True, text=True)


def panic_sites(elf):
    """[(address, callee)] of every call or tail call from outside the panic machinery into it."""
    dis = subprocess.run(
        [tool("llvm-objdump"), "-d", "--no-show-raw-insn", "-C", str(elf)],
        capture_output=True, text=True, check=True,
    ).stdout
    funcs = {}  # address -> demangled name
    for m in re.finditer(r"^([0-9a-f]+) <(.*)>:$", dis, re.M):
        funcs[int(m.group(1), 16)] = m.group(2)
    panics = {a for a, n in funcs.items() if PANIC_SYMBOL.search(n)}
    sites, current = [], None
    for line in dis.splitlines():
        m = re.match(r"^([0-9a-f]+) <(.*)>:$", line)
        if m:
            current = int(m.group(1), 16)
            continue
        m = re.match(r"^\s*([0-9a-f]+):\s+(bl|blx|b|b\.w|b\.n)\s+0x([0-9a-f]+)", line)
        if m and current not in panics and int(m.group(3), 16) in panics:
            sites.append((int(m.group(1), 16), funcs[int(m.group(3), 16)]))
    return sites


def where(elf, addr):
    """The inlining chain at `addr`, innermost first: [(function, repo-relative file:line)]."""
    out = subprocess.run(
        [tool("llvm-addr2line"), "-e", str(elf), "-f", "-C", "-i", hex(addr)],
        capture_output=True, text=True, check=True,
    ).stdout.splitlines()
    chain = []
    for fn, loc in zip(out[0::2], out[1::2]):
        path = loc.split(" ")[0]
        try:
            rel = str(Path(path).resolve().relative_to(REPO))
        except ValueError:
            continue  # the standard library
        chain.append((fn, rel))
    return chain


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-build", action="store_true", help="use the existing release build")
    ap.add_argument("-v", action="store_true", help="print the inlining chain of every site")
    args = ap.parse_args()
    if not args.no_build:
        r = build()
        if r.returncode != 0:
            sys.exit(f"check_no_panic: the example does not build:\n{r.stderr}")
    elf = target_dir() / TARGET / "release" / BIN
    sites = panic_sites(elf)
    bad, allowed = [], []
    for addr, callee in sites:
        chain = where(elf, addr)
        file = chain[0][1].rsplit(":", 1)[0] if chain else "?"
        text = f"{chain[0][1] if chain else hex(addr)} -> {callee}"
        if args.v:
            text += "".join(f"\n    in {fn} ({loc})" for fn, loc in chain)
        (allowed if file in ALLOWED else bad).append(text)
    for t in allowed:
        print(f"notice: known panic site (set-up, see ALLOWED): {t}")
    if bad:
        print(f"check_no_panic: {len(bad)} panic site(s) in the head's build:")
        for t in bad:
            print(f"  {t}")
        return 1
    if allowed:
        print(f"check_no_panic: ok, no panic site outside {sorted(ALLOWED)}")
        return 0
    r = build("no-panic")
    if r.returncode != 0:
        print(f"check_no_panic: no call site found, but the no-panic build fails:\n{r.stderr}")
        return 1
    print("check_no_panic: ok, the no-panic build links: no panic path in the head")
    return 0


if __name__ == "__main__":
    sys.exit(main())
