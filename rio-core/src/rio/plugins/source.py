"""Adding a `Spec(...)` to a plugin module's hook list, the way a person would edit it: `rio new driver`
registers the driver it generates without rewriting the user's file. The edit works on the parsed
source (ast positions), keeps everything else byte for byte, and is checked by parsing the result;
anything it cannot edit safely raises `CannotEdit` rather than guessing."""

from __future__ import annotations

import ast


def indent(entry: str, spaces: int) -> str:
    """`entry` (one or more lines) indented by `spaces`."""
    return "\n".join(" " * spaces + line for line in entry.splitlines())


class CannotEdit(Exception):
    """plugin.py is not in a shape `add_spec` edits safely."""


def add_spec(text: str, hook: str, entry: str) -> str:
    """`text` (a plugin module) with `entry` (a `Spec(...)` expression) added to the list literal that
    hook function `hook` returns; the hook is appended (as `@hookimpl def hook(): return [entry]`) when
    the module has none. Raises CannotEdit rather than guess."""
    try:
        tree = ast.parse(text)
    except SyntaxError as e:
        raise CannotEdit(f"it does not parse ({e.msg}, line {e.lineno})") from None
    fns = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == hook]
    if not fns:
        imported = {a.asname or a.name for n in tree.body if isinstance(n, ast.ImportFrom) for a in n.names}
        if not {"hookimpl", "Spec"} <= imported:
            raise CannotEdit(f"it has no {hook}() and does not import both hookimpl and Spec by name")
        block = f"\n\n@hookimpl\ndef {hook}() -> list[Spec]:\n    return [\n{indent(entry, 8)},\n    ]\n"
        return _checked(text.rstrip("\n") + "\n" + block, hook, 0)
    returns = [n for n in ast.walk(fns[0]) if isinstance(n, ast.Return)]
    if len(returns) != 1 or not isinstance(returns[0].value, ast.List):
        raise CannotEdit(f"{hook}() does not end in one `return [...]` of a list literal")
    ret, lst = returns[0], returns[0].value
    lines = text.splitlines(keepends=True)

    def at(lineno: int, col: int) -> int:
        """Offset in `text` of an ast position (whose columns count UTF-8 bytes)."""
        return sum(len(x) for x in lines[: lineno - 1]) + len(lines[lineno - 1].encode()[:col].decode())

    def span(node: ast.AST) -> tuple[int, int, int, int]:
        """(start line, start offset, end line, end offset) of `node` in `text`."""
        line, col = getattr(node, "lineno", None), getattr(node, "col_offset", None)
        end_line, end_col = getattr(node, "end_lineno", None), getattr(node, "end_col_offset", None)
        if line is None or col is None or end_line is None or end_col is None:
            raise CannotEdit(f"no source position for part of {hook}()")
        return line, at(line, col), end_line, at(end_line, end_col)

    first_line, start, last_line, end = span(lst)
    ret_line = lines[ret.lineno - 1]
    ret_indent = len(ret_line) - len(ret_line.lstrip())
    if first_line != last_line and lines[last_line - 1].strip().startswith("]"):
        # a list written one element per line: add the entry as its last element
        closing = at(last_line, 0)
        column = lst.elts[0].col_offset if lst.elts else ret_indent + 4
        head = text[:closing]
        if lst.elts:
            last_end = span(lst.elts[-1])[3]
            if not text[last_end:closing].lstrip().startswith(","):
                head = text[:last_end] + "," + text[last_end:closing]
        new = head + indent(entry, column) + ",\n" + text[closing:]
    else:
        # a list on one line (or an unusual layout): write it out one element per line
        items = [ast.get_source_segment(text, e) for e in lst.elts]
        known = [i for i in items if i is not None]
        if len(known) != len(items):
            raise CannotEdit(f"cannot read the elements of the list {hook}() returns")
        body = "".join(indent(i, ret_indent + 4) + ",\n" for i in [*known, entry])
        new = text[:start] + "[\n" + body + " " * ret_indent + "]" + text[end:]
    return _checked(new, hook, len(lst.elts))


def _checked(text: str, hook: str, had: int) -> str:
    """`text` if its `hook` returns a list of `had + 1` elements, else CannotEdit."""
    try:
        tree = ast.parse(text)
    except SyntaxError:
        raise CannotEdit(f"adding to {hook}() would not leave valid Python") from None
    fn = next((n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == hook), None)
    ret = [n for n in ast.walk(fn) if isinstance(n, ast.Return)] if fn is not None else []
    if len(ret) != 1 or not isinstance(ret[0].value, ast.List) or len(ret[0].value.elts) != had + 1:
        raise CannotEdit(f"adding to {hook}() did not give the expected list")
    return text
