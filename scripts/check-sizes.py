#!/usr/bin/env python3
"""The size limits of issue 28: no source file over 800 lines before its `#[cfg(test)] mod`,
no function over 150 lines (counted from the `fn` line to its closing brace, rustfmt's layout
assumed). Prints each offender and exits 1 when there is one.

    scripts/check-sizes.py [FOLDER...]    (default: src)
"""
import pathlib
import re
import sys

FILE_LIMIT, FN_LIMIT = 800, 150
FN = re.compile(r'^(\s*)(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?(extern\s+"[^"]*"\s+)?fn\s+(\w+)')
TEST_MOD = re.compile(r'(pub(\([^)]*\))?\s+)?mod\s+\w+')


def lines_before_tests(lines):
    """The index of the `#[cfg(test)]` that opens a top-level test module, else the length."""
    for i, line in enumerate(lines):
        if line.startswith("#[cfg(test)]"):
            j = i + 1
            while j < len(lines) and (lines[j].startswith("#[") or not lines[j].strip()):
                j += 1
            if j < len(lines) and TEST_MOD.match(lines[j]):
                return i
    return len(lines)


def long_functions(lines, end):
    """(length, line, name) of every function before `end` longer than the limit."""
    for i, line in enumerate(lines[:end]):
        m = FN.match(line)
        if not m or line.rstrip().endswith("}"):
            continue
        k = i
        while k < len(lines) and not lines[k].rstrip().endswith(("{", ";")):
            k += 1
        if k >= len(lines) or lines[k].rstrip().endswith(";"):
            continue  # a declaration without a body
        e = k + 1
        while e < len(lines) and lines[e].rstrip() != m.group(1) + "}":
            e += 1
        if e - i + 1 > FN_LIMIT:
            yield e - i + 1, i + 1, m.group(8)


def main(roots):
    bad = 0
    for root in roots:
        for path in sorted(pathlib.Path(root).rglob("*.rs")):
            lines = path.read_text().split("\n")
            if lines and lines[-1] == "":
                lines.pop()
            end = lines_before_tests(lines)
            if end > FILE_LIMIT:
                print(f"file {path}: {end} lines before its tests (limit {FILE_LIMIT})")
                bad += 1
            for length, line, name in long_functions(lines, end):
                print(f"fn   {path}:{line} {name}: {length} lines (limit {FN_LIMIT})")
                bad += 1
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or ["src"]))
