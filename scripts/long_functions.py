#!/usr/bin/env python3
"""Lists the functions longer than a limit (100 lines by default) in the C++ sources.

A function is a brace block opened at namespace or class scope by a line whose text (with the lines
before it up to the previous `;`, `{` or `}`) has a parameter list: its length counts the lines from
that signature's first line to its closing brace. Lambdas and blocks inside a function count
towards it. Files or functions that are tables or generated code are exempted by a comment
`// long-function: table` on the signature's line or the line above it.

Exit status 1 when a function is over the limit, so CI can run it (tests/CMakeLists.txt does).
With --known FILE, the functions listed there (one per line: length, path, signature, as this
script prints them) are the debt still to pay: each may stay up to its listed length, and only a new
long function or a listed one that grew fails. Pay it down by shortening a function and deleting
its line.
Usage: scripts/long_functions.py [--limit N] [--known FILE] [DIR ...]   (default: include src models solvers)
       scripts/long_functions.py --self-test   (plants functions of known lengths and checks the verdicts)
"""
import argparse
import os
import re
import sys

SOURCE_EXTENSIONS = (".cpp", ".hpp", ".h", ".cc")
CONTROL = re.compile(r"^\s*(if|for|while|switch|catch|do|else)\b")


def strip_comments_and_strings(text):
    """Blanks comments, string and character literals, keeping line breaks."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif text.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', text[i:])
            end = text.find(")" + (m.group(1) if m else "") + '"', i)
            j = n if end < 0 else end + len(m.group(1) if m else "") + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(" " * (min(j + 1, n) - i))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def long_functions(path, limit):
    with open(path, encoding="utf-8", errors="replace") as f:
        original = f.read()
    raw_lines = original.split("\n")
    text = strip_comments_and_strings(original)
    found = []
    # Scopes: 'ns' (namespace, class, struct, enum, extern) or 'fn' (a function body and what is in it).
    stack = []
    statement_start = 0  # offset of the text since the last ; { or } at namespace/class scope
    line_of = [0] * (len(text) + 1)
    line = 1
    for k, ch in enumerate(text):
        line_of[k] = line
        if ch == "\n":
            line += 1
    line_of[len(text)] = line
    for k, ch in enumerate(text):
        in_function = any(kind == "fn" for kind, _, _ in stack)
        if ch == "{":
            if in_function:
                stack.append(("block", k, None))
                continue
            head = text[statement_start:k]
            head_stripped = head.strip()
            is_function = ("(" in head_stripped and ")" in head_stripped
                           and not re.match(r"^(namespace|class|struct|enum|union|extern)\b", head_stripped)
                           and not re.search(r"=\s*$", head_stripped)
                           and not CONTROL.match(head_stripped))
            if is_function:
                # The signature starts after any access label (`public:`) that precedes it.
                label = re.match(r"\s*((public|private|protected)\s*:(?!:)\s*)*", head)
                first = statement_start + label.end()
                stack.append(("fn", first, None))
            else:
                stack.append(("ns", k, None))
            statement_start = k + 1
        elif ch == "}":
            if not stack:
                continue
            kind, start, _ = stack.pop()
            if kind == "fn":
                first_line, last_line = line_of[start], line_of[k]
                length = last_line - first_line + 1
                marker = " ".join(raw_lines[max(first_line - 2, 0):first_line])
                if length > limit and "long-function: table" not in marker:
                    signature = " ".join(text[start:text.find("(", start)].split())[-80:]
                    found.append((length, path, first_line, signature))
            if not any(kind2 == "fn" for kind2, _, _ in stack):
                statement_start = k + 1
        elif ch == ";" and not in_function:
            statement_start = k + 1
    return found


def self_test():
    """Plants functions of 100 and 101 lines (with comments, strings, lambdas and a class around them)
    and checks what is reported; returns the number of failed checks."""
    import tempfile

    def function(name, lines):
        body = [f"  int x = {i};  // {{ not a brace" for i in range(lines - 4)]
        return [f"int {name}(int a,", "        int b) {"] + body + ['  return a + b + std::string("}").size();', "}"]

    source = (["#include <string>", "namespace demo {", "class Holder {", " public:"]
              + function("fits", 100) + function("too_long", 101)
              + ["};", "// long-function: table"] + function("table", 150)
              + ["auto lambda_holder = [] { return 1; };", "}  // namespace demo", ""])
    failures = 0
    with tempfile.TemporaryDirectory() as top:
        path = os.path.join(top, "planted.cpp")
        with open(path, "w", encoding="utf-8") as f:
            f.write("\n".join(source))
        found = long_functions(path, 100)
        names = [(length, signature.split()[-1]) for length, _, _, signature in found]
        if names != [(101, "too_long")]:
            print(f"self-test: expected [(101, 'too_long')], found {names}")
            failures += 1
    print("self-test: " + ("passed" if failures == 0 else f"{failures} check(s) failed"))
    return failures


def main():
    if sys.argv[1:] == ["--self-test"]:
        return 1 if self_test() else 0
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--limit", type=int, default=100, help="longest allowed function, in lines [100]")
    parser.add_argument("--known", help="the long functions allowed for now (length<TAB>path<TAB>signature)")
    parser.add_argument("dirs", nargs="*", default=["include", "src", "models", "solvers"])
    args = parser.parse_args()
    if args.limit < 1:
        sys.exit(f"--limit {args.limit}: must be >= 1")
    known = {}
    if args.known:
        with open(args.known, encoding="utf-8") as f:
            for number, entry in enumerate(f, 1):
                entry = entry.rstrip("\n")
                if not entry or entry.startswith("#"):
                    continue
                fields = entry.split("\t")
                if len(fields) != 3 or not fields[0].isdigit():
                    sys.exit(f"{args.known}:{number}: '{entry}': expected length<TAB>path<TAB>signature")
                known[(fields[1], fields[2])] = int(fields[0])
    found = []
    for top in args.dirs:
        if not os.path.isdir(top):
            sys.exit(f"{top}: not a directory")
        for root, _, files in os.walk(top):
            for name in sorted(files):
                if name.endswith(SOURCE_EXTENSIONS):
                    found += long_functions(os.path.join(root, name), args.limit)
    failing = 0
    for length, path, line, signature in sorted(found, reverse=True):
        allowed = known.get((path, signature))
        if allowed is None:
            verdict = "new"
        elif length > allowed:
            verdict = f"grew from {allowed}"
        else:
            verdict = "known"
        failing += verdict != "known"
        print(f"{path}:{line}: {length} lines: {signature} [{verdict}]")
    print(f"{len(found)} function(s) over {args.limit} lines, {failing} of them new or grown")
    if args.known:
        print("the known ones, to paste into the --known file:")
        for length, path, _, signature in sorted(found, reverse=True):
            print(f"{length}\t{path}\t{signature}")
    return 1 if failing else 0


if __name__ == "__main__":
    sys.exit(main())
