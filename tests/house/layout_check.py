#!/usr/bin/env python3
"""The house rules of docs/architecture.md, checked on the product sources.

No product source file over 600 lines and no C++ function over 120 lines
(bench/ and tests/ are exempt). Function bodies are found by brace matching on
the source with comments and literals removed, which is enough for this code
base's style; `--report` lists the longest functions and files.

Usage: layout_check.py ROOT [--report]
       layout_check.py --self-test   (the checker finds breaches it must find)
Exit 0 when every rule holds, 1 naming each breach.
"""
import pathlib
import re
import sys

MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 120
PRODUCT_DIRS = ("station", "server", "patient_db", "proto")
SOURCE_SUFFIXES = {".cc", ".h", ".inc", ".js", ".proto", ".py", ".html", ".css"}
CPP_SUFFIXES = {".cc", ".h", ".inc"}


def is_product(path: pathlib.Path, root: pathlib.Path) -> bool:
    rel = path.relative_to(root)
    if rel.parts[0] not in PRODUCT_DIRS or path.suffix not in SOURCE_SUFFIXES:
        return False
    return not re.search(r"(_test|_fuzz)\.", path.name) and "tests" not in rel.parts


def strip_cpp(text: str) -> str:
    """Blanks comments, string and character literals, keeping newlines."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i)
            end = n if end < 0 else end + len(m.group(1)) + 2
            out.append('""' + "\n" * text.count("\n", i, end))
            i = end
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


SCOPE_RE = re.compile(r'\b(namespace|extern\s*""|class|struct|union|enum)\b')
CONTROL_RE = re.compile(r"^\s*(if|for|while|switch|catch|do|else|try)\b")


def functions(text: str):
    """Yields (name, first_line, last_line) of each function body at file,
    namespace or class scope."""
    code = strip_cpp(text)
    # Preprocessor lines (with their continuations) are not code for braces.
    code = re.sub(r"(?m)^[ \t]*#(?:[^\n]*\\\n)*[^\n]*", "", code)
    stack = []  # (kind, start_line, name)
    header_start = 0
    line = 1
    for i, c in enumerate(code):
        if c == "\n":
            line += 1
        elif c in ";{}":
            if c == "{":
                header = code[header_start:i]
                outer = stack[-1][0] if stack else "ns"
                if outer != "ns":
                    kind = "other"
                elif SCOPE_RE.search(header) and "(" not in header.split("{")[0].split(SCOPE_RE.search(header).group(0))[0]:
                    kind = "ns"
                elif ")" in header and not header.rstrip().endswith("=") and not CONTROL_RE.match(header):
                    kind = "fn"
                else:
                    kind = "other"
                stripped = header.lstrip()
                start = line - code[header_start + (len(header) - len(stripped)):i].count("\n")
                name = ""
                m = re.search(r"([~\w:<>]+)\s*\([^()]*(\([^()]*\)[^()]*)*\)[^()]*$", header)
                if m:
                    name = m.group(1)
                stack.append((kind, start, name))
            elif c == "}" and stack:
                kind, start, name = stack.pop()
                if kind == "fn":
                    yield name, start, line
            header_start = i + 1
    return


def self_test() -> int:
    """A 121-line function and a 601-line file are breaches; a 120-line
    function, braces in comments, strings and preprocessor lines are not."""
    body = "\n".join(f"  x += {i};" for i in range(118))
    long_fn = "int Long(int x) {\n" + body + "\n  return x;\n}\n"  # 121 lines
    ok_fn = "int Ok(int x) {\n" + "\n".join(body.splitlines()[:117]) + "\n  return x;\n}\n"
    noise = '// {{{ not code\nconst char* s = "{{";\n#define OPEN {\nnamespace a {\nstruct S {\n'
    got = {name: last - first + 1 for name, first, last in functions(noise + long_fn + ok_fn + "};\n}\n")}
    failures = []
    if got.get("Long") != 121:
        failures.append(f"Long measured {got.get('Long')} lines, want 121")
    if got.get("Ok") != 120:
        failures.append(f"Ok measured {got.get('Ok')} lines, want 120")
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        src = pathlib.Path(tmp) / "server"
        src.mkdir()
        (src / "big.cc").write_text("int a;\n" * (MAX_FILE_LINES + 1))
        (src / "fine.cc").write_text(ok_fn)
        (src / "fine_test.cc").write_text(long_fn)  # tests are exempt
        breaches = check(pathlib.Path(tmp), report=False)
        want = ["server/big.cc: 601 lines (at most 600)"]
        if breaches != want:
            failures.append(f"breaches {breaches}, want {want}")
    for f in failures:
        print("self-test:", f)
    print("self-test:", "passed" if not failures else "FAILED")
    return 1 if failures else 0


def main() -> int:
    if "--self-test" in sys.argv:
        return self_test()
    root = pathlib.Path(sys.argv[1]).resolve()
    breaches = check(root, report="--report" in sys.argv)
    for b in breaches:
        print(b)
    print(f"{len(breaches)} breaches of the house rules (files <= {MAX_FILE_LINES} lines, "
          f"functions <= {MAX_FUNCTION_LINES} lines; docs/architecture.md)")
    return 1 if breaches else 0


def check(root: pathlib.Path, report: bool):
    """The breaches under ROOT, one line each; with `report`, prints the
    longest files and functions too."""
    root = root.resolve()
    breaches = []
    longest = []
    files = []
    for path in sorted(root.rglob("*")):
        if not path.is_file() or "build" in path.relative_to(root).parts[:1]:
            continue
        if not is_product(path, root):
            continue
        rel = path.relative_to(root)
        text = path.read_text(encoding="utf-8", errors="replace")
        n = text.count("\n")
        files.append((n, str(rel)))
        if n > MAX_FILE_LINES:
            breaches.append(f"{rel}: {n} lines (at most {MAX_FILE_LINES})")
        if path.suffix in CPP_SUFFIXES:
            for name, first, last in functions(text):
                length = last - first + 1
                longest.append((length, f"{rel}:{first} {name}"))
                if length > MAX_FUNCTION_LINES:
                    breaches.append(f"{rel}:{first}: function {name or '?'} is {length} lines (at most {MAX_FUNCTION_LINES})")
    if report:
        print("longest files:")
        for n, f in sorted(files, reverse=True)[:15]:
            print(f"  {n:5d} {f}")
        print("longest functions:")
        for n, f in sorted(longest, reverse=True)[:25]:
            print(f"  {n:5d} {f}")
    if report:
        print(f"{len(files)} product files checked, {len(longest)} functions; {len(breaches)} breaches")
    return breaches


if __name__ == "__main__":
    sys.exit(main())
