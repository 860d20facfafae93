"""C text shared by the emitters of tree and loop code: string literals and the name tables of states, parameters,
outputs, constraint rows and frames (one writer, so every table reads alike)."""

from __future__ import annotations

from collections.abc import Sequence


def c_string(text: str) -> str:
    """A C string literal of `text` (escapes quotes, backslashes, '?' against trigraphs, non-ASCII as octal)."""
    out = []
    for byte in text.encode("utf-8"):
        c = chr(byte)
        if c in '"\\?':
            out.append("\\" + c)
        elif 32 <= byte < 127:
            out.append(c)
        else:
            out.append(f"\\{byte:03o}")
    return '"' + "".join(out) + '"'


def name_table(function: str, what: str, names: Sequence[str]) -> str:
    """`const char *function(int i)`: names[i] (`what` says which, e.g. "state i"), NULL when out of range."""
    lines = [f"/* Name of {what}, NULL when out of range. */", f"const char *{function}(int i)", "{"]
    if names:
        lines.append("    static const char *const names[] = {")
        row = "       "
        for q in (c_string(n) + "," for n in names):
            if len(row) + len(q) > 110:
                lines.append(row)
                row = "       "
            row += " " + q
        lines += [row, "    };", f"    return (i >= 0 && i < {len(names)}) ? names[i] : NULL;"]
    else:
        lines += ["    (void)i;", "    return NULL;"]
    return "\n".join(lines + ["}\n"])
