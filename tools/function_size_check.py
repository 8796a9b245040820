#!/usr/bin/env python3
"""Fails when a function body in the project's C++ sources is longer than the style limit.

The brief's style rule is "functions under ~80 lines". A function's size here is the number
of physical lines strictly between the line of its body's opening brace and the line of its
closing brace (blank and comment lines included: they are lines a reader scrolls through).
A body of more than --limit lines (default 80) fails, unless the function is in the allowlist
(tools/function_size_allowlist.txt) with at least its current size; an allowlisted function
that grows past its recorded size fails too, and an entry that no longer matches a function
over the limit fails so the list only shrinks.

No compiler is needed: the sources are clang-formatted, so after comments, strings and
preprocessor lines are blanked, every '{' can be matched with its '}', and a brace at
namespace or class scope whose head ends in a parameter list (plus qualifiers, a trailing
return type or a constructor's initializer list) opens a function body. Lambdas and local
classes count towards the function they are written in. GoogleTest's TEST(...) bodies are
functions named after the macro.

Usage: function_size_check.py [--limit N] [--allowlist FILE] [--root DIR] [FILE...]
Without FILEs it checks every .h/.cpp under the project's source folders of --root.
Prints one line per finding as FILE:LINE: function NAME has N lines (limit L) and exits 1.
"""
import argparse
import os
import re
import sys

# The project's own C++ sources (tools/tidy_check.py uses these too).
SOURCE_DIRS = ["base", "bench", "calib", "daemon", "drivers", "io", "lab", "nav", "plans",
               "tests", "tools"]
# Not ours to restyle: third-party code kept in the tree.
EXCLUDED = {"tools/cli11.h"}
CONTROL = {"if", "for", "while", "switch", "catch", "do", "else", "try", "return"}
AGGREGATE = re.compile(r"^(?:template\s*<.*>\s*)?(?:typedef\s+)?(?:class|struct|union|enum)\b")


def blank_non_code(text):
    """Returns text with comments, string/char literals and preprocessor lines replaced by
    spaces (newlines kept, so offsets and line numbers are unchanged)."""
    out = list(text)
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if c == "\n":
            at_line_start = True
            i += 1
            continue
        if at_line_start and c in " \t":
            i += 1
            continue
        if at_line_start and c == "#":  # preprocessor line, with its continuations
            j = i
            while j < n and not (text[j] == "\n" and text[j - 1] != "\\"):
                j += 1
            _blank(out, i, j)
            i = j
            continue
        at_line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            _blank(out, i, j)
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            _blank(out, i, j)
            i = j
        elif c == "R" and text.startswith('"', i + 1) and not _ident_char(text, i - 1):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i + m.end())
            j = n if end < 0 else end + len(m.group(1)) + 2
            _blank(out, i, j)
            i = j
        elif c in "\"'":
            if c == "'" and _ident_char(text, i - 1) and text[i - 1].isdigit():
                i += 1  # digit separator, 1'000
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            _blank(out, i, min(j + 1, n))
            i = j + 1
        else:
            i += 1
    return "".join(out)


def _blank(out, start, end):
    for k in range(start, end):
        if out[k] != "\n":
            out[k] = " "


def _ident_char(text, i):
    return i >= 0 and (text[i].isalnum() or text[i] == "_")


def strip_angles(head):
    """Removes template argument lists <...> (not operator<, <<, <=) from a head."""
    out, depth = [], 0
    i = 0
    while i < len(head):
        c = head[i]
        before = head[:i].rstrip()
        if c == "<" and not before.endswith("operator") and not head.startswith("<<", i) \
                and (depth > 0 or re.search(r"[\w>]\s*$", head[:i]) or before.endswith("template")):
            depth += 1
        elif c == ">" and depth > 0 and not head.startswith("->", i - 1):
            depth -= 1
        elif depth == 0:
            out.append(c)
        i += 1
    return "".join(out)


def function_name(head):
    """The function a brace head defines, or None when the head is not a function's."""
    head = " ".join(head.split())
    if not head or AGGREGATE.match(head) or head.startswith(("namespace", "extern")):
        return None
    head = re.sub(r"\[\[.*?\]\]", " ", head)
    flat = strip_angles(head)
    if "=" in re.sub(r"operator\s*\S+?\s*\(|\(.*?\)|==|<=|>=|!=", "", flat):
        return None  # a variable's brace initializer, a lambda assigned to a variable
    m = re.search(r"((?:[\w~]+::)*(?:operator\s*(?:\(\)|[^\s(]+)|~?\w+))\s*\(", flat)
    if not m or m.group(1).split("::")[-1] in CONTROL:
        return None
    # After the parameter list only qualifiers, a trailing return type or an initializer list.
    depth, k = 0, m.end() - 1
    while k < len(flat):
        depth += {"(": 1, ")": -1}.get(flat[k], 0)
        if depth == 0:
            break
        k += 1
    if depth != 0:
        return None  # an unclosed call: a brace inside a macro's or a call's arguments
    tail = flat[k + 1:].strip()
    if tail.startswith(":") and re.search(r"[\w>]$", tail):
        return ""  # a member's brace initializer in a constructor's initializer list
    if tail and not re.match(r"^(const|noexcept|override|final|mutable|volatile|&|&&|->|:|"
                             r"try\b|requires\b|\()", tail):
        return None
    name = m.group(1)
    if re.fullmatch(r"(TEST|TEST_F|TEST_P|TYPED_TEST|TYPED_TEST_P)", name):
        args = re.search(r"\((.*?)\)", head)
        name = "%s(%s)" % (name, args.group(1).replace(" ", "") if args else "")
    return name


def functions(text):
    """Yields (name, open_line, body_lines) of every function body in a file's text."""
    code = blank_non_code(text)
    line_of = []
    line = 1
    for ch in code:
        line_of.append(line)
        line += ch == "\n"
    stack = []  # (kind, open offset, name); kind in {'scope', 'function', 'other'}
    head_start = 0
    for i, ch in enumerate(code):
        if ch in ";":
            if not stack or stack[-1][0] == "scope":
                head_start = i + 1
        elif ch == "{":
            inside_function = any(kind not in ("scope", "init") for kind, _, _ in stack)
            if inside_function:
                stack.append(("other", i, None))
                continue
            head = code[head_start:i]
            head = re.sub(r"^\s*(public|private|protected)\s*:", "", head)
            name = function_name(head)
            if name == "":
                stack.append(("init", i, None))
                continue
            if name:
                stack.append(("function", i, name))
            elif AGGREGATE.match(" ".join(head.split())) or re.match(
                    r"^\s*(namespace\b|extern\b)", head):
                stack.append(("scope", i, None))
            else:
                stack.append(("other", i, None))
            head_start = i + 1
        elif ch == "}":
            if not stack:
                continue
            kind, start, name = stack.pop()
            if kind == "function":
                yield name, line_of[start], line_of[i] - line_of[start] - 1
            if kind == "init":
                continue
            if not stack or stack[-1][0] == "scope":
                head_start = i + 1
        elif ch == ":" and (not stack or stack[-1][0] == "scope"):
            # An access specifier ends the previous head.
            if re.search(r"\b(public|private|protected)\s*$", code[head_start:i]):
                head_start = i + 1


def load_allowlist(path):
    """Reads 'FILE_BASENAME FUNCTION LINES  reason...' lines ('#' starts a comment line)."""
    entries = {}
    if not path or not os.path.exists(path):
        return entries
    with open(path, encoding="utf-8") as f:
        for number, raw in enumerate(f, 1):
            raw = raw.strip()
            if not raw or raw.startswith("#"):
                continue
            parts = raw.split(None, 3)
            if len(parts) < 4 or not parts[2].isdigit():
                sys.exit("%s:%d: expected 'FILE FUNCTION LINES reason', got: %s" %
                         (path, number, raw))
            entries[(parts[0], parts[1])] = (int(parts[2]), number)
    return entries


def source_files(root):
    files = []
    for top in SOURCE_DIRS:
        for dirpath, _, names in os.walk(os.path.join(root, top)):
            for name in names:
                rel = os.path.relpath(os.path.join(dirpath, name), root)
                if name.endswith((".h", ".cpp")) and rel not in EXCLUDED:
                    files.append(rel)
    return sorted(files)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--limit", type=int, default=80, help="most body lines (default 80)")
    parser.add_argument("--root", default=".", help="project root (default: .)")
    parser.add_argument("--allowlist", help="allowlist file (default: "
                        "ROOT/tools/function_size_allowlist.txt when no FILE is given)")
    parser.add_argument("--list", action="store_true", help="print every function over the "
                        "limit as an allowlist line, then exit 0")
    parser.add_argument("files", nargs="*")
    args = parser.parse_args()
    files = args.files or source_files(args.root)
    allow_path = args.allowlist
    if allow_path is None and not args.files:
        allow_path = os.path.join(args.root, "tools", "function_size_allowlist.txt")
    allowed = load_allowlist(allow_path)
    seen, failures, count = set(), [], 0
    for rel in files:
        path = rel if os.path.isabs(rel) or args.files else os.path.join(args.root, rel)
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
        for name, line, size in functions(text):
            count += 1
            if size <= args.limit:
                continue
            key = (os.path.basename(rel), name)
            if args.list:
                print("%s %s %d  TODO reason" % (key[0], name, size))
                continue
            if key in allowed:
                seen.add(key)
                if size > allowed[key][0]:
                    failures.append("%s:%d: function %s has %d lines, more than the %d its "
                                    "allowlist entry (%s:%d) records: shorten it" %
                                    (rel, line, name, size, allowed[key][0], allow_path,
                                     allowed[key][1]))
                continue
            failures.append("%s:%d: function %s has %d lines (limit %d): split it, or add "
                            "'%s %s %d  <reason>' to the allowlist" %
                            (rel, line, name, size, args.limit, key[0], name, size))
    if args.list:
        return 0
    if not args.files:
        for key, (size, number) in sorted(allowed.items(), key=lambda kv: kv[1][1]):
            if key not in seen:
                failures.append("%s:%d: allowlisted function %s in %s is gone or no longer over "
                                "%d lines: remove the entry" %
                                (allow_path, number, key[1], key[0], args.limit))
    for failure in failures:
        print(failure, file=sys.stderr)
    if failures:
        print("function size check: %d finding(s); a function body may have at most %d lines "
              "(tools/function_size_check.py)" % (len(failures), args.limit), file=sys.stderr)
        return 1
    print("function size check: %d functions in %d files, none over %d lines beyond the "
          "%d allowlisted" % (count, len(files), args.limit, len(seen)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
