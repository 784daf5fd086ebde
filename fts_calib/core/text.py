"""Plain-text tables for reports that people read (numbers formatted by the caller)."""

from __future__ import annotations


def table(headers: list[str], rows: list[list[str]], indent: str = "  ") -> str:
    """Render rows as a left-aligned text table (numbers should be formatted already)."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)]
    lines = [indent + "  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True)).rstrip()]
    lines += [indent + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]
    return "\n".join(lines)
