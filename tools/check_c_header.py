#!/usr/bin/env python3
"""Hold core/ffi/include/fringe3d.h (kept by hand) equal to core/ffi/src/ (the C ABI).

Checks, in both directions:
- every `extern "C" fn` of the library has a prototype in the header with the same name, the
  same parameters (names and C types, in order) and the same return type, and the header
  declares no function the library does not define (besides `fringe3d_panic`, the firmware's);
- every `pub const FRINGE3D_*` has a `#define` of the same value, and the other way round;
- the fields of each `#[repr(C)] pub struct` of the library are the C struct's, in order.

Rust types map to C as the ABI does: usize -> size_t, u32 -> uint32_t, i32 -> int32_t,
u8 -> uint8_t, u16 -> uint16_t, f32 -> float, c_char -> char, `*const T` -> `const T *`,
`*mut T` -> `T *`. Run by .ci/run; exits non-zero naming each difference.
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "core/ffi/src"
HEADER = ROOT / "core/ffi/include/fringe3d.h"
# Declared in the header for the firmware to define (the library calls it on a panic).
FIRMWARE_PROVIDES = {"fringe3d_panic"}

SCALARS = {
    "usize": "size_t",
    "u32": "uint32_t",
    "i32": "int32_t",
    "u8": "uint8_t",
    "u16": "uint16_t",
    "u64": "uint64_t",
    "f32": "float",
    "c_char": "char",
}


def c_type(rust: str) -> str:
    """The C spelling of a Rust FFI type, normalised (`const T *`, single spaces)."""
    rust = rust.strip()
    for prefix, const in (("*const ", True), ("*mut ", False)):
        if rust.startswith(prefix):
            inner = c_type(rust[len(prefix):])
            if inner.endswith("*"):
                # a pointer to a pointer: the inner pointer's constness goes after its star
                return norm(f"{inner} const *" if const else f"{inner} *")
            return norm(f"const {inner} *" if const else f"{inner} *")
    return SCALARS.get(rust, rust)


def norm(c: str) -> str:
    c = re.sub(r"\s+", " ", c.strip())
    c = re.sub(r"\s*\*\s*", " * ", c)
    return re.sub(r"\s+", " ", c).strip()


def rust_functions(src: str) -> dict:
    out = {}
    pat = re.compile(
        r'pub (?:unsafe )?extern "C" fn (\w+)\((.*?)\)(?:\s*->\s*([^{]+?))?\s*\{', re.S
    )
    for name, args, ret in pat.findall(src):
        params = []
        for a in filter(None, (x.strip() for x in args.split(","))):
            pname, ptype = a.split(":", 1)
            params.append((pname.strip(), norm(c_type(ptype))))
        out[name] = (params, norm(c_type(ret)) if ret else "void")
    return out


def header_functions(hdr: str) -> dict:
    body = re.sub(r"/\*.*?\*/", " ", hdr, flags=re.S)
    body = re.sub(r"^\s*#.*$", " ", body, flags=re.M)
    body = re.sub(r"__attribute__\s*\(\(.*?\)\)", " ", body)
    out = {}
    for m in re.finditer(r"([\w\s\*]+?)\b(fringe3d_\w+)\s*\(([^()]*)\)\s*;", body):
        ret, name, args = m.groups()
        params = []
        if args.strip() != "void":
            for a in args.split(","):
                a = a.strip()
                pm = re.match(r"(.*?)(\w+)$", a, re.S)
                params.append((pm.group(2), norm(pm.group(1))))
        out[name] = (params, norm(ret.replace("typedef", "")))
    return out


def rust_consts(src: str) -> dict:
    return {
        n: int(v.replace("_", ""))
        for n, v in re.findall(r"pub const (FRINGE3D_\w+): \w+ = (-?[\d_]+);", src)
    }


def header_defines(hdr: str) -> dict:
    return {
        n: int(v)
        for n, v in re.findall(r"^#define (FRINGE3D_\w+) (-?\d+)u?\b", hdr, flags=re.M)
    }


def rust_structs(src: str) -> dict:
    out = {}
    for name, body in re.findall(
        r"#\[repr\(C\)\]\s*(?:#\[derive[^\]]*\]\s*)?pub struct (\w+) \{(.*?)\n\}", src, re.S
    ):
        fields = []
        for fname, ftype in re.findall(r"(?:pub )?(\w+): ([^,\n]+),", body):
            m = re.match(r"\[(\w+); (\w+)\]", ftype.strip())
            if m:
                fields.append((fname, f"{c_type(m.group(1))}[{m.group(2)}]"))
            else:
                fields.append((fname, norm(c_type(ftype))))
        out[name] = fields
    return out


def header_structs(hdr: str) -> dict:
    out = {}
    body = re.sub(r"/\*.*?\*/", " ", hdr, flags=re.S)
    for name, fields in re.findall(r"typedef struct (\w+) \{(.*?)\}\s*\1;", body, re.S):
        parsed = []
        for f in filter(None, (x.strip() for x in fields.split(";"))):
            m = re.match(r"(.*?)(\w+)\s*(?:\[(\w+)\])?$", f, re.S)
            ctype, fname, dim = norm(m.group(1)), m.group(2), m.group(3)
            parsed.append((fname, f"{ctype}[{dim}]" if dim else ctype))
        out[name] = parsed
    return out


def main() -> int:
    src = "\n".join(p.read_text() for p in sorted(SRC.glob("*.rs")))
    hdr = HEADER.read_text()
    problems = []
    rf, hf = rust_functions(src), header_functions(hdr)
    for name, sig in rf.items():
        if name not in hf:
            problems.append(f"{name}: in the library, not in the header")
        elif hf[name] != sig:
            problems.append(f"{name}: library {sig} vs header {hf[name]}")
    for name in hf.keys() - rf.keys() - FIRMWARE_PROVIDES:
        problems.append(f"{name}: in the header, not in the library")
    rc, hd = rust_consts(src), header_defines(hdr)
    for name in rc.keys() | hd.keys():
        if rc.get(name) != hd.get(name):
            problems.append(f"{name}: library {rc.get(name)} vs header {hd.get(name)}")
    rs, hs = rust_structs(src), header_structs(hdr)
    for name in rs.keys() | hs.keys():
        if rs.get(name) != hs.get(name):
            problems.append(f"struct {name}: library {rs.get(name)} vs header {hs.get(name)}")
    if not rf or not rc or not rs:
        problems.append("found no functions, constants or structs: is the parser stale?")
    for p in problems:
        print(f"check_c_header: {p}", file=sys.stderr)
    if problems:
        return 1
    print(
        f"check_c_header: ok, {len(rf)} functions, {len(rc)} constants, {len(rs)} structs agree"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
