#!/usr/bin/env python3
"""Lists C++ functions longer than N lines in the given folders or files.

Prints one `path:line name length` row per function, longest first. A function is a `{` at
file, namespace or class scope whose signature ends in `)` (then qualifiers, a trailing return
type or a constructor's initializer list); its length counts the lines from the one holding its
name to the one holding its closing brace. Comments, string and character literals and
preprocessor lines are blanked first so that braces inside them do not count. This is a
heuristic tuned to this codebase's style, not a parser: macros that open or close braces, or
signatures split by `#if`, can confuse it.

Exit status: 0, also when it finds functions (it lists, it does not judge).
"""

import argparse
import os
import re
import sys

SUFFIXES = (".cpp", ".cc", ".cxx", ".hpp", ".h", ".hh", ".hxx", ".inl", ".ipp")

# What may stand between a parameter list's `)` and the body's `{`.
TRAILING = re.compile(
    r"\)\s*(?:(?:const|volatile|noexcept(?:\s*\([^()]*\))?|override|final|mutable|&&|&|"
    r"try|\[\[[^\]]*\]\])\s*)*(?:->[^{;]*)?$"
)
CTOR_INIT = re.compile(r"\)\s*(?:noexcept\s*)?:(?!:)")
SCOPE_KEYWORD = re.compile(r"\b(?:class|struct|union|enum)\b")
NAMESPACE = re.compile(r'(?:\bnamespace\b[\w\s:]*|\bextern\s*"[^"]*"\s*)$')
NAME = re.compile(
    r"(operator\s*(?:\(\s*\)|\[\s*\]|[^\s\w(]+|\w[\w\s:<>*&]*?)|"
    r"(?:[\w~]+(?:<[^<>]*>)?\s*::\s*)*~?\w+)\s*$"
)


def blank(text):
    """Returns text with comments, literals and preprocessor lines replaced by spaces.

    Newlines are kept so that offsets still map to the same lines; a literal keeps its quotes
    (so `"{"` becomes `" "`) to leave the surrounding tokens where they were.
    """
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#":
            # A preprocessor directive runs to an unescaped newline.
            while i < n and text[i] != "\n":
                if text[i] == "\\" and i + 1 < n and text[i + 1] == "\n":
                    out.append(" \n")
                    i += 2
                    continue
                out.append(" ")
                i += 1
            continue
        if c == "\n":
            out.append(c)
            i += 1
            line_start = True
            continue
        if c in " \t\r\f\v":
            out.append(c)
            i += 1
            continue
        line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
            continue
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        raw = re.match(r'(?:u8|u|U|L)?R"([^()\\\s]{0,16})\(', text[i:i + 24])
        if raw and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            end = text.find(")" + raw.group(1) + '"', i + raw.end())
            j = n if end < 0 else end + len(raw.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        if c == "'" and is_digit_separator(text, i):
            out.append(c)
            i += 1
            continue
        if c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + " " * max(0, j - i - 2) + (c if j - i >= 2 else ""))
            i = j
            continue
        out.append(c)
        i += 1
    return "".join(out)


def is_digit_separator(text, i):
    """Whether the `'` at i separates digits of a number (1'000), not a character literal."""
    j = i
    while j > 0 and (text[j - 1].isalnum() or text[j - 1] in "_.'"):
        j -= 1
    return j < i and text[j].isdigit()


def is_body(signature):
    """Whether a `{` after this signature text opens a function body."""
    if signature.count("(") != signature.count(")"):
        return False  # a braced argument inside a call, as in a delegating constructor
    if CTOR_INIT.search(signature):
        # After an initializer list the body follows a member's `(...)` or `{...}`; a `{`
        # right after a member's name is that member's braced initializer.
        return signature.endswith((")", "}"))
    return bool(TRAILING.search(signature))


def signature_name(signature):
    """The function's name from its signature (text before the body's `{`), or '?'."""
    init = CTOR_INIT.search(signature)
    head = signature[: init.start() + 1] if init else signature
    depth = 0
    for k, c in enumerate(head):
        depth += {"(": 1, ")": -1}.get(c, 0)
        if depth == 0 and head.startswith("->", k):
            head = head[:k]  # a trailing return type
            break
    close = head.rfind(")")
    if close < 0:
        return "?"
    depth = 0
    for k in range(close, -1, -1):
        if head[k] == ")":
            depth += 1
        elif head[k] == "(":
            depth -= 1
            if depth == 0:
                match = NAME.search(head[:k])
                if not match:
                    return "?"
                return re.sub(r"\s+", "", match.group(1))
    return "?"


def functions(text):
    """Yields (line, name, length) for each function body at file, namespace or class scope."""
    code = blank(text)
    stack = []  # one entry per open `{`: (kind, signature start offset, name)
    statement_start = 0
    for i, c in enumerate(code):
        if c == ";":
            if not stack or stack[-1][0] in ("namespace", "class"):
                statement_start = i + 1
        elif c == "{":
            if stack and stack[-1][0] not in ("namespace", "class"):
                stack.append(("block", 0, ""))
                continue
            signature = code[statement_start:i]
            stripped = signature.strip()
            if NAMESPACE.search(stripped):
                stack.append(("namespace", 0, ""))
                statement_start = i + 1
            elif is_body(stripped):
                name = signature_name(stripped)
                # The signature's first line may hold only a template header or return type;
                # count from the line holding the name.
                at = code.rfind(name.split("::")[-1], statement_start, i) if name != "?" else -1
                start = at if at >= 0 else statement_start + len(signature) - len(signature.lstrip())
                stack.append(("function", start, name))
            elif SCOPE_KEYWORD.search(stripped) and not stripped.endswith("="):
                stack.append(("class", 0, ""))
                statement_start = i + 1
            else:
                # An initializer (`= {...}`, `x_{1}` in an initializer list): not a scope.
                stack.append(("init", 0, ""))
        elif c == "}":
            if not stack:
                continue
            kind, start, name = stack.pop()
            if kind == "function":
                first = code.count("\n", 0, start) + 1
                last = code.count("\n", 0, i) + 1
                yield first, name, last - first + 1
                statement_start = i + 1
            elif kind in ("namespace", "class"):
                statement_start = i + 1


def source_files(paths):
    for path in paths:
        if os.path.isfile(path):
            yield path
            continue
        for root, dirs, files in os.walk(path):
            dirs[:] = sorted(d for d in dirs if not d.startswith("."))
            for name in sorted(files):
                if name.endswith(SUFFIXES):
                    yield os.path.join(root, name)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="+", help="folders or C++ files to read")
    parser.add_argument("-n", "--lines", type=int, default=120,
                        help="list functions longer than this many lines (default 120)")
    args = parser.parse_args()
    rows = []
    for path in source_files(args.paths):
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
        for line, name, length in functions(text):
            if length > args.lines:
                rows.append((-length, path, line, name))
    for negative_length, path, line, name in sorted(rows):
        print(f"{path}:{line} {name} {-negative_length}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
