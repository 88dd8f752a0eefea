#!/usr/bin/env python3
"""Check that the Rust names the docs mention still exist in the sources.

Usage: python3 tools/check_doc_symbols.py [--root DIR] [-v] [FILE.md ...]

Reads the Markdown files (default: README.md, every */README.md next to a Cargo.toml, and
docs/**/*.md), takes the code spans (`...`) and the fenced ```rust blocks, and extracts:

* paths such as `math::atan2`, `Decoder::finish_lanes`, `fringe3d::batch::decode_frames`
  (generics and turbofish removed): the last segment must be defined somewhere in the repository's
  Rust sources, and every earlier segment must name a module, a crate or a type;
* calls such as `decode_row_with()` or `reconstruct_row(ring, v, ...)`, and method calls in
  ```rust blocks: the name must be defined;
* a span that is one bare identifier with an underscore or an inner capital (`decode_row_with`,
  `ScalarGather`): defined, or at least a word of the sources' code or string literals (not
  comments: TOML, JSON and OpenCV keys, preset and scene names are strings there; intrinsics and
  attributes are used in code; a format string such as "frame_{w}_batch_{isa}" covers the
  names it builds);
* `something.rs`: a file of that name exists; `dir/path` starting at a top-level entry of the
  repository (`core/src/decode.rs`, `host/tests/`): that path exists;
* `cargo ... -p PKG --bench/--test/--example NAME [-- FILTER]` (code spans and shell blocks):
  the package and the target exist, and a test-name filter is part of some function's name.

"Defined" means: fn, struct, enum, union, trait, type, const, static, mod, macro_rules!, an enum
variant, a field (or a parameter: `name:` after `{`, `(`, `,` or at a line start), a .rs file or
a source directory, or a package/target name from a Cargo.toml. Comments are not definitions.
Names rooted in an external crate (every package of a Cargo.lock with a `source`, plus std,
core, alloc and the primitive types) are not checked. Skipped: CLI flags, shell commands other
than cargo's, TOML/key = value spans, file paths outside the repository.

Prints every missing name as FILE:LINE and exits 1 if there is any; exits 0 otherwise.
Standard library only; reads every .rs file once (about a second on this repository).
"""

import argparse
import os
import re
import sys
from pathlib import Path

# Words that look like Rust names in the docs but are not this repository's symbols. Keep short;
# each entry says why.
IGNORE = {
    # Rust attributes and std / core methods the docs discuss
    "no_std",
    "no_main",
    "mul_add",
    "leading_zeros",
    "round_ties_even",
}

# Roots of paths that are not ours even though no Cargo.lock lists them.
EXTERNAL_ROOTS = {
    "std", "core", "alloc", "proc_macro", "test",
    "f32", "f64", "i8", "i16", "i32", "i64", "i128", "isize",
    "u8", "u16", "u32", "u64", "u128", "usize", "bool", "char", "str",
    "Vec", "Option", "Result", "Box", "String", "Some", "None", "Ok", "Err",
    "Default", "Clone", "From", "Into", "Iterator", "IntoIterator", "AsRef",
    "cv",  # OpenCV (C++) names
    "np", "numpy",  # Python
}

# Standard names allowed as calls or methods in ```rust blocks.
STD_CALLS = {
    "Some", "Ok", "Err", "Box", "Vec", "String", "Default", "default", "new", "from", "into",
    "unwrap", "expect", "as_ref", "as_mut", "as_slice", "iter", "iter_mut", "map", "collect",
    "len", "is_empty", "clone", "to_vec", "push", "get", "zip", "enumerate", "chunks_exact",
    "chunks_exact_mut", "as_path", "join", "parse", "to_bits", "min", "max", "abs", "sum",
}

RUST_KEYWORDS = {
    "as", "break", "const", "continue", "crate", "else", "enum", "extern", "false", "fn", "for",
    "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return",
    "self", "Self", "static", "struct", "super", "trait", "true", "type", "unsafe", "use",
    "where", "while", "async", "await", "dyn", "union",
}

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"

# --------------------------------------------------------------------------------------------
# Rust sources


_RUST_TOKEN = re.compile(
    r"""
      (?P<line>//[^\n]*)
    | (?P<block>/\*)
    | (?P<raw>(?<!\w)b?r(?P<hashes>\#*)")
    | (?P<str>(?<!\w)b?"(?:\\.|[^"\\])*")
    | (?P<chr>(?<!\w)b?'(?:\\(?:u\{[0-9a-fA-F]+\}|x[0-9a-fA-F]{2}|.)|[^'\\\n])')
    """,
    re.VERBOSE | re.DOTALL,
)


def split_rust(text):
    """Return (code, strings): the source with comments and literals blanked, and the string
    literals' contents."""
    out = []
    strings = []
    pos = 0
    n = len(text)
    while pos < n:
        m = _RUST_TOKEN.search(text, pos)
        if not m:
            out.append(text[pos:])
            break
        out.append(text[pos : m.start()])
        if m.group("line") is not None:
            out.append(" ")
            pos = m.end()
        elif m.group("block") is not None:
            # nested block comments
            depth, i = 1, m.end()
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    i += 1
            out.append("\n" * text.count("\n", m.start(), i))
            pos = i
        elif m.group("raw") is not None:
            end = '"' + m.group("hashes")
            j = text.find(end, m.end())
            j = n if j < 0 else j + len(end)
            strings.append(text[m.end() : j - len(end)])
            out.append('""' + "\n" * text.count("\n", m.start(), j))
            pos = j
        elif m.group("str") is not None:
            s = m.group("str")
            strings.append(s[s.index('"') + 1 : -1])
            out.append('""' + "\n" * s.count("\n"))
            pos = m.end()
        else:  # char literal
            out.append("' '")
            pos = m.end()
    return "".join(out), strings


_DEF = re.compile(
    r"(?=\b(?:fn|struct|enum|union|trait|type|mod|const|static)\s+(?:mut\s+)?(?:r#)?("
    + IDENT
    + r"))"
)
_FN = re.compile(r"\bfn\s+(?:r#)?(" + IDENT + ")")
_MACRO = re.compile(r"\bmacro_rules!\s*(" + IDENT + ")")
_MODLIKE = re.compile(r"\b(?:mod|struct|enum|union|trait|type)\s+(?:r#)?(" + IDENT + ")")
_FIELD_LINE = re.compile(
    r"^\s*(?:pub(?:\s*\([^)]*\))?\s+)?(?:r#)?(" + IDENT + r")\s*:(?!:)", re.MULTILINE
)
_FIELD_INLINE = re.compile(r"[{(,]\s*(?:pub(?:\s*\([^)]*\))?\s+)?(?:r#)?(" + IDENT + r")\s*:(?!:)")
_ENUM = re.compile(r"\benum\s+" + IDENT + r"[^{;]*\{")
_STR_WORD = re.compile(IDENT)


def _enum_variants(code, names):
    for m in _ENUM.finditer(code):
        i, depth, start = m.end(), 1, m.end()
        pieces = []
        while i < len(code) and depth:
            c = code[i]
            if c in "{([":
                depth += 1
            elif c in "})]":
                depth -= 1
            elif c == "," and depth == 1:
                pieces.append(code[start:i])
                start = i + 1
            i += 1
        pieces.append(code[start : i - 1])
        for p in pieces:
            p = re.sub(r"#\s*!?\[[^\]]*\]", " ", p)  # attributes (no nested brackets needed here)
            v = re.match(r"\s*(" + IDENT + ")", p)
            if v:
                names.add(v.group(1))
                # serde's rename_all = "snake_case" / "lowercase" spellings
                names.add(re.sub(r"(?<=[a-z0-9])([A-Z])", r"_\1", v.group(1)).lower())
                names.add(v.group(1).lower())


def _templates(s):
    """Regexes for the identifiers a format string builds: "frame_{w}x{h}_batch_{isa}" gives
    `frame_\\w+x\\w+_batch_\\w+` (benchmark ids, test case names)."""
    out = []
    for tok in re.findall(r"[\w{}:?#.]+", s):
        if "{" not in tok or "}" not in tok:
            continue
        lit = re.split(r"\{[^{}]*\}", tok)
        if sum(len(x) for x in lit) < 3 or not all(re.fullmatch(r"\w*", x) for x in lit):
            continue
        out.append(r"\w+".join(re.escape(x) for x in lit))
    return out


def skip_dir(name):
    return name in {"target", ".git", "node_modules", "__pycache__"} or name.startswith("target")


def index_sources(root):
    """Names defined in the repository, names usable as a path segment, string-literal words,
    every repository file path (relative), .rs basenames, package and target names."""
    defined, modlike, strwords, fns, templates = set(), set(), set(), set(), set()
    files, rs_basenames = set(), set()
    packages, targets = set(), set()
    external = set(EXTERNAL_ROOTS)
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = [d for d in dirnames if not skip_dir(d)]
        rel_dir = os.path.relpath(dirpath, root)
        if rel_dir != ".":
            files.add(rel_dir.replace(os.sep, "/"))
        for f in filenames:
            rel = os.path.normpath(os.path.join(rel_dir, f)).replace(os.sep, "/")
            files.add(rel)
            path = os.path.join(dirpath, f)
            if f.endswith(".rs"):
                rs_basenames.add(f)
                stem = f[:-3]
                defined.add(stem)
                modlike.add(stem)
                parent = os.path.basename(dirpath)
                defined.add(parent)
                modlike.add(parent)
                try:
                    text = open(path, encoding="utf-8", errors="replace").read()
                except OSError:
                    continue
                code, strings = split_rust(text)
                defined.update(m.group(1) for m in _DEF.finditer(code))
                defined.update(m.group(1) for m in _MACRO.finditer(code))
                fns.update(m.group(1) for m in _FN.finditer(code))
                modlike.update(m.group(1) for m in _MODLIKE.finditer(code))
                defined.update(m.group(1) for m in _FIELD_LINE.finditer(code))
                defined.update(m.group(1) for m in _FIELD_INLINE.finditer(code))
                _enum_variants(code, defined)
                for s in strings:
                    strwords.update(_STR_WORD.findall(s))
                    if "{" in s:
                        templates.update(_templates(s))
                strwords.update(_STR_WORD.findall(code))
            elif f == "Cargo.toml":
                _cargo_toml(path, rel_dir, packages, targets)
            elif f == "Cargo.lock":
                _cargo_lock(path, external)
    for p in packages:
        defined.add(p.replace("-", "_"))
        modlike.add(p.replace("-", "_"))
    defined.update(t.replace("-", "_") for t in targets)
    external -= {p.replace("-", "_") for p in packages}
    return {
        "defined": defined,
        "modlike": modlike | {"crate", "self", "super", "Self"},
        "strwords": strwords,
        "fns": fns,
        "templates": [re.compile(t) for t in sorted(templates)],
        "files": files,
        "rs": rs_basenames,
        "packages": packages,
        "targets": targets,
        "external": external,
    }


def _cargo_toml(path, rel_dir, packages, targets):
    section = None
    try:
        lines = open(path, encoding="utf-8").read().splitlines()
    except OSError:
        return
    off = set()  # `autotests = false` and the like: that kind of target is not discovered
    for line in lines:
        s = line.strip()
        if s.startswith("["):
            section = s.strip("[]").strip()
            continue
        a = re.match(r"auto(tests|benches|examples|bins)\s*=\s*false", s)
        if a and section == "package":
            off.add({"tests": "tests", "benches": "benches", "examples": "examples",
                     "bins": "src/bin"}[a.group(1)])
        m = re.match(r'name\s*=\s*"([^"]+)"', s)
        if m and section == "package":
            packages.add(m.group(1))
        elif m and section in ("bin", "bench", "test", "example"):
            targets.add(m.group(1))
    # auto-discovered targets
    base = os.path.dirname(path)
    for sub in ("benches", "tests", "examples", "src/bin"):
        d = os.path.join(base, sub)
        if os.path.isdir(d) and sub not in off:
            for f in os.listdir(d):
                if f.endswith(".rs"):
                    targets.add(f[:-3])
                elif os.path.isfile(os.path.join(d, f, "main.rs")):
                    targets.add(f)


def _cargo_lock(path, external):
    try:
        text = open(path, encoding="utf-8").read()
    except OSError:
        return
    for block in text.split("[[package]]"):
        m = re.search(r'^name = "([^"]+)"', block, re.MULTILINE)
        if m and re.search(r"^source = ", block, re.MULTILINE):
            external.add(m.group(1).replace("-", "_"))


# --------------------------------------------------------------------------------------------
# Markdown


_FENCE = re.compile(r"^\s*(```+|~~~+)\s*([A-Za-z0-9_+-]*)")


def markdown_parts(text):
    """Yield ('span', line, content) for inline code spans and ('block', line, lang, content)
    lines of fenced blocks (one per line)."""
    lines = text.split("\n")
    prose = []  # (line_no, text) outside fences
    fence = None
    lang = ""
    for no, line in enumerate(lines, 1):
        m = _FENCE.match(line)
        if fence is None and m:
            fence, lang = m.group(1), m.group(2).lower()
            prose.append((no, ""))
            continue
        if fence is not None:
            if line.strip().startswith(fence[0] * len(fence)) and line.strip().strip(fence[0]) == "":
                fence = None
                prose.append((no, ""))
            else:
                yield ("block", no, lang, line)
                prose.append((no, ""))
            continue
        prose.append((no, line))
    # code spans may cross a line break, never a blank line
    joined = "\n".join(t for _, t in prose)
    starts = [0]
    for t in prose:
        starts.append(starts[-1] + len(t[1]) + 1)
    for m in re.finditer(r"(?<!`)(`+)(?!`)(.+?)(?<!`)\1(?!`)", joined, re.DOTALL):
        body = m.group(2)
        if "\n\n" in body:
            continue
        off = m.start()
        line_idx = _bisect(starts, off)
        yield ("span", prose[line_idx][0], body.replace("\n", " ").strip())


def _bisect(starts, off):
    lo, hi = 0, len(starts) - 1
    while lo < hi - 1:
        mid = (lo + hi) // 2
        if starts[mid] <= off:
            lo = mid
        else:
            hi = mid
    return lo


# --------------------------------------------------------------------------------------------
# Checks


_PATH = re.compile(r"(?<![\w:.$/])(" + IDENT + r"(?:\s*::\s*(?:<[^<>]*(?:<[^<>]*>[^<>]*)*>|" + IDENT + r"))+)")
_CALL = re.compile(r"^(" + IDENT + r")\s*\(.*\)$")
_METHOD = re.compile(r"\.\s*(" + IDENT + r")\s*(?:::\s*<[^>]*>\s*)?\(")
_FREE_CALL = re.compile(r"(?<![\w.:!])(" + IDENT + r")\s*\(")
_BARE = re.compile(r"^" + IDENT + r"$")
_SHELL_WORDS = {
    "bash", "sh", "python", "python3", "valgrind", "perf", "qemu-system-arm", "rustup", "git",
    "cd", "ls", "time", "make", "pip", "cmake", "fringe3d", "fringe3d-head", "env", "sudo",
    "apt-get", "cargo",
}
# libtest / criterion options that take a value (the value is not a test-name filter)
_VALUE_FLAGS = {
    "--test-threads", "--format", "--color", "--logfile", "-Z", "--save-baseline", "--baseline",
    "--measurement-time", "--warm-up-time", "--sample-size", "--profile-time", "--skip",
}
_REPO_PATH = re.compile(r"^\.?[A-Za-z0-9_.-]+(?:/[A-Za-z0-9_.*-]*)+$")


class Checker:
    def __init__(self, idx):
        self.idx = idx
        self.problems = []

    def report(self, where, what):
        self.problems.append(f"{where}: {what}")

    def defined(self, name):
        return name in self.idx["defined"] or name in IGNORE

    def check_path(self, where, path, ctx):
        segs = [s for s in re.split(r"\s*::\s*", path) if s and not s.startswith("<")]
        if len(segs) < 2:
            return
        if segs[0] in self.idx["external"] or segs[0] in IGNORE:
            return
        for s in segs[:-1]:
            if s not in self.idx["modlike"] and s not in IGNORE:
                self.report(where, f"no module, crate or type `{s}` (in `{ctx}`)")
                return
        if not self.defined(segs[-1]):
            self.report(where, f"`{segs[-1]}` is not defined anywhere (in `{ctx}`)")

    def check_cargo(self, where, cmd):
        words = cmd.split()
        if not words or words[0] != "cargo":
            return
        if "--" in words and len(words) > 1 and words[1] in ("test", "bench", "run"):
            # test-name filters after `--` must be part of some function's name (for benches:
            # of some name in the code or its strings, criterion's ids are strings there)
            pool = self.idx["fns"] if words[1] == "test" else self.idx["fns"] | self.idx["strwords"]
            after = words[words.index("--") + 1 :]
            for i, w in enumerate(after):
                w = w.strip("`'\"")
                if i > 0 and after[i - 1] in _VALUE_FLAGS:
                    continue
                if words[1] == "run" or not re.match(r"^[A-Za-z_]\w*$", w):
                    continue
                if not any(w in d for d in pool):
                    self.report(where, f"no function name contains the filter `{w}` (in `{cmd}`)")
            words = words[: words.index("--")]
        for flag, kind in (("-p", "package"), ("--package", "package"), ("--bench", "target"),
                           ("--test", "target"), ("--example", "target"), ("--bin", "target")):
            for i, w in enumerate(words[:-1]):
                if w == flag:
                    name = words[i + 1].strip("`'\"")
                    if name.startswith("-") or not re.match(r"^[A-Za-z0-9_-]+$", name):
                        continue
                    pool = self.idx["packages"] if kind == "package" else self.idx["targets"]
                    if name not in pool:
                        self.report(where, f"cargo {kind} `{name}` does not exist (in `{cmd}`)")
            for w in words:
                if w.startswith(flag + "="):
                    name = w.split("=", 1)[1]
                    pool = self.idx["packages"] if kind == "package" else self.idx["targets"]
                    if name not in pool:
                        self.report(where, f"cargo {kind} `{name}` does not exist (in `{cmd}`)")

    def check_file(self, where, span):
        s = span.rstrip(".,;:")
        if s.endswith(".rs") and "/" not in s and " " not in s:
            if s not in self.idx["rs"]:
                self.report(where, f"no file `{s}` in the repository")
            return True
        if " " in s or not _REPO_PATH.match(s):
            return False
        first = s.split("/")[0]
        if first not in self.idx["top"]:
            return True  # a dataset path, a target path, a path relative to a crate: not checked
        if "*" in s or "<" in s:
            return True
        if s.rstrip("/") not in self.idx["files"]:
            self.report(where, f"no path `{s}` in the repository")
        return True

    def check_span(self, where, span):
        if not span or span.startswith("-"):
            return
        first = span.split()[0]
        if " " in span and first in _SHELL_WORDS:
            if first == "cargo":
                self.check_cargo(where, span)
            return
        if self.check_file(where, span):
            return
        for m in _PATH.finditer(span):
            self.check_path(where, m.group(1), span)
        m = _CALL.match(span)
        if m and not span.isascii():
            return  # mathematics: `exp(−2π²σ²f₀²)`, `Rz(c)·Ry(b)·Rx(a)`
        if m:
            name = m.group(1)
            if name not in RUST_KEYWORDS and not self.defined(name):
                self.report(where, f"`{name}` is not defined anywhere (in `{span}`)")
            return
        if _BARE.match(span) and span not in RUST_KEYWORDS:
            interesting = "_" in span.strip("_") or re.search(r"[a-z][A-Z]", span)
            if re.match(r"^[A-Za-z]{1,2}_[A-Za-z0-9]{1,3}$", span):
                interesting = False  # a subscript: `f_x`, `c_k`
            if (
                interesting
                and not self.defined(span)
                and span not in self.idx["strwords"]
                and not any(t.fullmatch(span) for t in self.idx["templates"])
            ):
                self.report(where, f"`{span}` appears nowhere in the sources' code or strings")

    def check_rust_line(self, where, line):
        code = re.sub(r"//.*$", "", line)
        code = re.sub(r'"(?:\\.|[^"\\])*"', '""', code)
        for m in _PATH.finditer(code):
            self.check_path(where, m.group(1), code.strip())
        for m in _METHOD.finditer(code):
            n = m.group(1)
            if n not in STD_CALLS and not self.defined(n):
                self.report(where, f"method `{n}` is not defined anywhere (in `{code.strip()}`)")
        for m in _FREE_CALL.finditer(code):
            n = m.group(1)
            if n in RUST_KEYWORDS or n in STD_CALLS or code[m.end(1) :].startswith("!"):
                continue
            if not self.defined(n):
                self.report(where, f"`{n}` is not defined anywhere (in `{code.strip()}`)")


def default_docs(root):
    docs = []
    for name in ["README.md"]:
        if (root / name).is_file():
            docs.append(root / name)
    for p in sorted(root.glob("*/README.md")):
        if (p.parent / "Cargo.toml").is_file():
            docs.append(p)
    docs.extend(sorted((root / "docs").rglob("*.md")))
    return docs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent)
    ap.add_argument("-v", "--verbose", action="store_true", help="print what was checked")
    ap.add_argument("files", nargs="*", type=Path)
    args = ap.parse_args()
    root = args.root.resolve()
    idx = index_sources(root)
    idx["top"] = {p for p in os.listdir(root) if not skip_dir(p)}
    checker = Checker(idx)
    docs = [f if f.is_absolute() else Path.cwd() / f for f in args.files] or default_docs(root)
    spans = 0
    for doc in docs:
        try:
            text = doc.read_text(encoding="utf-8")
        except OSError as e:
            print(f"{doc}: {e}", file=sys.stderr)
            return 2
        try:
            shown = doc.resolve().relative_to(root)
        except ValueError:
            shown = doc
        for part in markdown_parts(text):
            where = f"{shown}:{part[1]}"
            if part[0] == "span":
                spans += 1
                checker.check_span(where, part[2])
            else:
                lang, line = part[2], part[3]
                if lang == "rust":
                    checker.check_rust_line(where, line)
                elif lang in ("sh", "bash", "shell", "console", ""):
                    for cmd in re.split(r"&&|;|\|", line):
                        cmd = cmd.strip().lstrip("$ ").split("#")[0].strip()
                        if cmd.startswith("cargo "):
                            checker.check_cargo(where, cmd)
    for p in checker.problems:
        print(p)
    sys.stdout.flush()
    if args.verbose or checker.problems:
        print(
            f"{len(checker.problems)} problem(s) in {len(docs)} file(s), {spans} code spans; "
            f"{len(idx['defined'])} names defined in the sources",
            file=sys.stderr,
        )
    return 1 if checker.problems else 0


if __name__ == "__main__":
    sys.exit(main())
