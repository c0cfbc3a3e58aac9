#!/usr/bin/env python3
"""Report every C++ function whose body is longer than a limit (docs/framework.md, "Code size").

Usage: check_function_length.py [--max-lines N] [--allow FILE] [--root DIR] PATH...

PATH is a source file or a folder (searched recursively for .cpp .cc .cxx .h .hpp .hh .inl;
node_modules, hidden folders and build trees, i.e. folders holding a CMakeCache.txt, are skipped:
they are not our code).
A function's length is the number of physical lines from the line of its body's opening brace to
the line of its closing brace, both included: `void f() {` + 148 lines + `}` is 150 lines. Free
functions, member functions (in or out of the class), constructors (with initialiser lists),
operators, macro-defined bodies such as TEST(a, b) { ... }, and lambdas at namespace scope count;
a lambda or local class inside a function counts within its enclosing function. Namespace, class,
struct, union, enum and extern "C" bodies are scopes, not functions; brace initialisers
(`int a[] = {..}`, `T x{..}`) are neither.

The scanner is a small C++ lexer, not a compiler: comments, string and character literals (with
prefixes and raw strings R"d(...)d"), digit separators (1'000) and preprocessor lines (with
backslash continuations) are blanked before braces are matched. A file whose braces do not match
after that (an #if with unbalanced branches, say) is an error, never a silent pass.

--allow FILE names functions that may stay long for now, one per line:
    <path relative to --root>::<function name>   # who removes it, and why
A listed function that is no longer too long is reported as stale (a warning: remove the line).
Exit status: 0 when every function fits (or is allowed), 1 when one does not, 2 on a usage or
parse error.
"""

import argparse
import os
import re
import sys

SOURCE_EXTENSIONS = (".cpp", ".cc", ".cxx", ".h", ".hpp", ".hh", ".inl")
LITERAL_PREFIXES = {"L", "u", "U", "u8", "R", "LR", "uR", "UR", "u8R"}
SKIPPED_FOLDERS = {"node_modules", "__pycache__"}
CLASS_KEYS = {"class", "struct", "union", "enum"}
# Words that may follow a function's parameter list before its body.
TRAILING_QUALIFIERS = {"const", "volatile", "noexcept", "override", "final", "mutable",
                       "constexpr", "try", "&", "&&"}


class ParseError(Exception):
    """A file the scanner cannot read as C++ braces (message names file and line)."""


def blank_non_code(text, path):
    """Return text with comments, literals and preprocessor lines replaced by spaces.

    Newlines are kept, so line numbers of the result are those of the input. String and character
    literals become a single placeholder character ('"' for strings, "'" for characters) followed
    by spaces, so the token stream still shows that a literal was there (extern "C").
    """
    out = []
    i, n = 0, len(text)
    line = 1
    at_line_start = True  # only whitespace since the last newline

    def blank(segment):
        return "".join(c if c == "\n" else " " for c in segment)

    while i < n:
        c = text[i]
        if c == "\n":
            out.append(c)
            line += 1
            at_line_start = True
            i += 1
            continue
        if c in " \t\r\f\v":
            out.append(c)
            i += 1
            continue
        if c == "#" and at_line_start:
            # Preprocessor directive: up to an unescaped newline; comments inside are skipped too.
            j = i
            while j < n and text[j] != "\n":
                if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n":
                    j += 2
                    continue
                if text.startswith("/*", j):
                    end = text.find("*/", j + 2)
                    if end < 0:
                        raise ParseError(f"{path}:{line}: unterminated comment")
                    j = end + 2
                    continue
                if text.startswith("//", j):
                    while j < n and text[j] != "\n":
                        j += 2 if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n" else 1
                    break
                j += 1
            segment = text[i:j]
            out.append(blank(segment))
            line += segment.count("\n")
            i = j
            continue
        at_line_start = False
        if text.startswith("//", i):
            j = i
            while j < n and text[j] != "\n":
                j += 2 if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n" else 1
            segment = text[i:j]
            out.append(blank(segment))
            line += segment.count("\n")
            i = j
            continue
        if text.startswith("/*", i):
            end = text.find("*/", i + 2)
            if end < 0:
                raise ParseError(f"{path}:{line}: unterminated comment")
            segment = text[i:end + 2]
            out.append(blank(segment))
            line += segment.count("\n")
            i = end + 2
            continue
        if c.isalpha() or c == "_":
            j = i
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            word = text[i:j]
            if word in LITERAL_PREFIXES and j < n and text[j] in "\"'":
                out.append(" " * len(word))  # the prefix belongs to the literal that follows
                i = j
                if word.endswith("R") and text[j] == '"':
                    i, line = _skip_raw_string(text, i, line, path, out)
                continue
            out.append(word)
            i = j
            continue
        if c.isdigit() or (c == "." and i + 1 < n and text[i + 1].isdigit()):
            # A pp-number: digits, letters, '.', digit separators and exponent signs.
            j = i + 1
            while j < n:
                d = text[j]
                if d.isalnum() or d in "._":
                    j += 1
                elif d == "'" and j + 1 < n and (text[j + 1].isalnum() or text[j + 1] == "_"):
                    j += 1
                elif d in "+-" and text[j - 1] in "eEpP":
                    j += 1
                else:
                    break
            out.append(blank(text[i:j]).replace(" ", "0"))
            i = j
            continue
        if c in "\"'":
            i, line = _skip_quoted(text, i, line, path, out)
            continue
        out.append(c)
        i += 1
    return "".join(out)


def _skip_quoted(text, i, line, path, out):
    """Blank the string or character literal starting at text[i]; return (end index, line)."""
    quote = text[i]
    j = i + 1
    n = len(text)
    while j < n:
        d = text[j]
        if d == "\\":
            j += 2
            continue
        if d == quote:
            break
        if d == "\n":
            kind = "string" if quote == '"' else "character"
            raise ParseError(f"{path}:{line}: unterminated {kind} literal")
        j += 1
    if j >= n:
        raise ParseError(f"{path}:{line}: unterminated literal")
    out.append(quote + " " * (j - i))
    return j + 1, line


def _skip_raw_string(text, i, line, path, out):
    """Blank the raw string R"delim( ... )delim" whose quote is text[i]; return (end, line)."""
    open_paren = text.find("(", i + 1)
    if open_paren < 0 or open_paren - i - 1 > 16:
        raise ParseError(f"{path}:{line}: malformed raw string literal")
    delimiter = text[i + 1:open_paren]
    closing = ")" + delimiter + '"'
    end = text.find(closing, open_paren + 1)
    if end < 0:
        raise ParseError(f"{path}:{line}: unterminated raw string literal")
    end += len(closing)
    segment = text[i:end]
    out.append('"' + "".join(c if c == "\n" else " " for c in segment[1:]))
    return end, line + segment.count("\n")


TOKEN_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*|\d[\w.]*|::|->|[^\sA-Za-z_0-9]")


def _tokens(header):
    """Tokens of a declaration head, `operator<symbols>` merged into one token so that
    `operator=` or `operator()` is a name, not an assignment or a parameter list."""
    raw = TOKEN_RE.findall(header)
    tokens, k = [], 0
    while k < len(raw):
        if raw[k] != "operator":
            tokens.append(raw[k])
            k += 1
            continue
        j = k + 1
        if raw[j:j + 2] == ["(", ")"]:
            j += 2
        while j < len(raw) and raw[j] != "(":
            j += 1
        tokens.append("".join(raw[k:j]))
        k = j
    return _strip_templates(tokens)


def _strip_templates(tokens):
    """Drop leading `template <...>` heads and [[attributes]] from a declaration's tokens."""
    while True:
        if tokens[:1] == ["template"] and tokens[1:2] == ["<"]:
            depth, k = 0, 1
            while k < len(tokens):
                if tokens[k] == "<":
                    depth += 1
                elif tokens[k] == ">":
                    depth -= 1
                    if depth == 0:
                        break
                k += 1
            tokens = tokens[k + 1:]
        elif tokens[:2] == ["[", "["]:
            k = 2
            while k + 1 < len(tokens) and not (tokens[k] == "]" and tokens[k + 1] == "]"):
                k += 1
            tokens = tokens[k + 2:]
        else:
            return tokens


def _top_level(tokens):
    """(index, token) of the tokens outside any (), [] or {} group; a group's brackets count."""
    depth, result = 0, []
    for k, t in enumerate(tokens):
        if t in ("(", "[", "{"):
            if depth == 0:
                result.append((k, t))
            depth += 1
        elif t in (")", "]", "}"):
            depth -= 1
            if depth == 0:
                result.append((k, t))
        elif depth == 0:
            result.append((k, t))
    return result


def classify(header):
    """Classify the `{` that follows declaration text `header` at namespace or class scope.

    Returns "scope" (namespace, class, struct, union, enum, extern "C": its body holds
    declarations), "function" (a body of code) or "init" (a brace initialiser).
    """
    tokens = _tokens(header)
    if not tokens:
        return "init"  # a bare block at namespace scope does not exist; treat as data
    top = [t for _, t in _top_level(tokens)]
    if "namespace" in tokens[:2] and tokens[0] in ("namespace", "inline"):
        return "scope"
    if tokens == ["extern", '"']:
        return "scope"
    if top[-1] in ("=", ","):
        return "init"
    has_parens = "(" in top
    if not has_parens:
        # `class A : public B {`, `enum class E : int {` are scopes; `T x{`, `int a[] = {` data.
        return "scope" if any(t in CLASS_KEYS for t in top) and "=" not in top else "init"
    if "=" in top:
        # `auto f = [](int a) {` is a lambda at namespace scope: a function body. Anything else
        # with `=` before the brace (`int v = f(x) + T{`) is an initialiser.
        rest = top[top.index("=") + 1:]
        return "function" if rest[:1] == ["["] and _ends_like_signature(tokens) else "init"
    return "function" if _ends_like_signature(tokens) else "init"


def _ends_like_signature(tokens):
    """True when tokens end like a function head: `(...)` then qualifiers, a trailing return
    type (`-> T`) or a constructor initialiser list (`: a(x), b{y}`)."""
    top = _top_level(tokens)
    closes = [k for k, t in top if t == ")"]
    if not closes:
        return False
    if ":" in [t for k, t in top if k > closes[0]]:
        return True  # Foo::Foo(int a) : a_(a), b_{a}
    after = [t for k, t in top if k > closes[-1]]
    if "->" in after:
        return True  # auto f(int a) const -> int
    # Qualifiers; noexcept(...) and throw() end in ')' and so are already behind closes[-1].
    return all(t in TRAILING_QUALIFIERS for t in after)


def function_name(header):
    """A readable name for the function whose head is `header` (for messages and allow-lists)."""
    tokens = _tokens(header)
    top = _top_level(tokens)
    eq = [k for k, t in top if t == "="]
    if eq and tokens[eq[0] + 1:eq[0] + 2] == ["["]:
        return tokens[eq[0] - 1] if eq[0] > 0 else "<lambda>"  # auto name = [..](..) {
    first_paren = next((k for k, t in top if t == "("), None)
    if first_paren is None or first_paren == 0:
        return "<unknown>"
    k = first_paren - 1
    if not re.match(r"[A-Za-z_~]", tokens[k]):
        return "<unknown>"
    parts = [tokens[k]]
    k -= 1
    if k >= 0 and tokens[k] == "~":
        parts[0] = "~" + parts[0]
        k -= 1
    while k >= 1 and tokens[k] == "::" and re.match(r"[A-Za-z_]", tokens[k - 1]):
        parts.insert(0, tokens[k - 1])
        k -= 2
    name = "::".join(parts)
    if re.fullmatch(r"[A-Z][A-Z0-9_]*", name):
        # A macro that defines a body (TEST(Suite, Case) {): name it with its arguments.
        close = next(k for k, t in top if k > first_paren and t == ")")
        name += "(" + "".join(t + " " if t == "," else t for t in tokens[first_paren + 1:close]) + ")"
    return name


def scan_functions(text, path):
    """Return [(first line, last line, name)] of every function body in C++ source `text`."""
    code = blank_non_code(text, path)
    functions = []
    stack = []  # (kind, line of its '{', declaration head): kinds scope, function, init, block
    header_start = 0  # offset in `code` where the current declaration's text starts
    line = 1
    for i, c in enumerate(code):
        if c == "\n":
            line += 1
        elif c not in ";{}":
            continue
        elif stack and stack[-1][0] in ("function", "block", "init"):
            # Inside a body or an initialiser every brace is nested in it.
            if c == "{":
                stack.append(("init" if stack[-1][0] == "init" else "block", line, ""))
            elif c == "}":
                kind, first, header = stack.pop()
                if kind == "function":
                    functions.append((first, line, function_name(header)))
                    header_start = i + 1
        elif c == ";":
            header_start = i + 1
        elif c == "{":
            header = code[header_start:i]
            if _paren_depth(header) > 0:
                # A brace inside a call's arguments at namespace scope: a lambda's body
                # (REGISTER(x, [](int a) {) or data (f(a, T{..})).
                kind = "function" if _is_lambda_head(_argument_tail(header)) else "init"
                if kind == "function":
                    header = f"{_call_name(header)}_lambda = " + _argument_tail(header)
            else:
                kind = classify(header)
            stack.append((kind, line, header))
            if kind != "init":
                header_start = i + 1
            # An initialiser's braces stay in the head: `Foo() : b_{b} {` is still one head.
        else:  # '}' closing a scope
            if not stack:
                raise ParseError(f"{path}:{line}: '}}' closes nothing (unbalanced braces or #if branches)")
            stack.pop()
            header_start = i + 1
    if stack:
        raise ParseError(f"{path}:{stack[-1][1]}: '{{' never closed (unbalanced braces or #if branches)")
    return functions


def _open_position(header, stop_at_comma):
    """Index in `header` (which has an unclosed `(`) of its last unclosed bracket or, with
    stop_at_comma, of a comma at that depth if one comes later; -1 when there is none."""
    depth = 0
    for k in range(len(header) - 1, -1, -1):
        c = header[k]
        if c in ")]}":
            depth += 1
        elif c in "([{":
            if depth == 0:
                return k
            depth -= 1
        elif stop_at_comma and c == "," and depth == 0:
            return k
    return -1


def _argument_tail(header):
    """The text of the last, unfinished argument in `header` (which has an unclosed `(`)."""
    return header[_open_position(header, stop_at_comma=True) + 1:]


def _call_name(header):
    """The name of the call whose arguments are open at the end of `header`."""
    k = _open_position(header, stop_at_comma=False)
    if k < 0:
        return "<call>"
    m = re.search(r"([A-Za-z_][\w:]*)\s*$", header[:k])
    return m.group(1) if m else "<call>"


def _is_lambda_head(text):
    """True when `text` is a lambda's head: `[captures]`, then optionally `(params)`, qualifiers
    and a trailing return type."""
    tokens = TOKEN_RE.findall(text)
    top = _top_level(tokens)
    if not top or top[0][1] != "[":
        return False
    rest = [t for k, t in top[2:]]  # after `[` ... `]`
    if rest[:2] == ["(", ")"]:
        rest = rest[2:]
    if "->" in rest:
        rest = rest[:rest.index("->")]
    return all(t in TRAILING_QUALIFIERS for t in rest)


def _paren_depth(header):
    depth = 0
    for c in header:
        if c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
    return depth


def source_files(paths):
    """Every C++ source under `paths` (files taken as given), in a stable order."""
    for p in paths:
        if os.path.isfile(p):
            yield p
            continue
        if not os.path.isdir(p):
            raise ParseError(f"{p}: no such file or folder")
        for root, dirs, files in os.walk(p):
            # Not our code: installed third-party packages (npm's node_modules), version control
            # and build trees (a folder holding a CMakeCache.txt).
            dirs[:] = sorted(d for d in dirs if d not in SKIPPED_FOLDERS and not d.startswith(".")
                             and not os.path.exists(os.path.join(root, d, "CMakeCache.txt")))
            for f in sorted(files):
                if f.endswith(SOURCE_EXTENSIONS):
                    yield os.path.join(root, f)


def read_allow_list(path):
    """Parse an allow-list file into {(relative path, function name): line number}."""
    allowed = {}
    with open(path, encoding="utf-8") as f:
        for number, raw in enumerate(f, 1):
            entry = raw.split("#", 1)[0].strip()
            if not entry:
                continue
            if "::" not in entry:
                raise ParseError(f"{path}:{number}: expected '<path>::<function>', got '{entry}'")
            file_part, name = entry.split("::", 1)
            if "#" not in raw:
                raise ParseError(f"{path}:{number}: '{entry}' needs a comment saying who removes it")
            allowed[(file_part.strip(), name.strip())] = number
    return allowed


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("paths", nargs="+", help="source files or folders")
    parser.add_argument("--max-lines", type=int, default=150,
                        help="longest allowed function, in lines from '{' to '}' (default 150)")
    parser.add_argument("--allow", help="allow-list file (see the module documentation)")
    parser.add_argument("--root", default=".", help="paths in messages and the allow-list are relative to it")
    parser.add_argument("--list", action="store_true", help="print every function with its length")
    args = parser.parse_args(argv)
    if args.max_lines < 1:
        parser.error("--max-lines must be at least 1")
    try:
        allowed = read_allow_list(args.allow) if args.allow else {}
        too_long, allowed_seen, count = [], set(), 0
        for path in source_files(args.paths):
            rel = os.path.relpath(path, args.root)
            with open(path, encoding="utf-8", errors="surrogateescape") as f:
                text = f.read()
            for first, last, name in scan_functions(text, rel):
                count += 1
                length = last - first + 1
                if args.list:
                    print(f"{rel}:{first}: {name}: {length} lines")
                if length <= args.max_lines:
                    continue
                if (rel, name) in allowed:
                    allowed_seen.add((rel, name))
                    print(f"{rel}:{first}: allowed for now: {name} is {length} lines (limit {args.max_lines})")
                else:
                    too_long.append(f"{rel}:{first}: {name} is {length} lines (limit {args.max_lines}): "
                                    "split it into named steps")
    except (ParseError, OSError) as e:
        print(f"check_function_length: {e}", file=sys.stderr)
        return 2
    for key in sorted(set(allowed) - allowed_seen):
        print(f"{args.allow}:{allowed[key]}: warning: {key[0]}::{key[1]} is no longer over "
              f"{args.max_lines} lines (or no longer exists): remove it from the allow-list")
    for message in too_long:
        print(message)
    print(f"check_function_length: {count} functions, {len(too_long)} over {args.max_lines} lines"
          + (f", {len(allowed_seen)} allowed for now" if allowed_seen else ""))
    return 1 if too_long else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
