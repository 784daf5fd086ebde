"""Plain-text tables for reports that people read (numbers formatted by the caller)."""

from __future__ import annotations


def table(headers: list[str], rows: list[list[str]], indent: str = "  ") -> str:
    """Render rows as a left-aligned text table (numbers should be formatted already)."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)]
    lines = [indent + "  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True)).rstrip()]
    lines += [indent + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]
    return "\n".join(lines)


def utf8_safe(text: str) -> str:
    r"""Text that encodes as UTF-8: the undecodable bytes of a file name written as ``\xNN``.

    Python reads a file name that is not UTF-8 with its bad bytes as lone surrogates
    ("surrogate escapes"), which no UTF-8 file can hold: written as they are, they stop the
    writer (UnicodeEncodeError) or give a file no reader accepts. Every text written to a
    file goes through here (:func:`fts_calib.core.files.atomic_write_text`, ``to_plain``).

    Args:
        text: Any text.

    Returns:
        ``text`` itself when it encodes as UTF-8; otherwise the same text with each
        undecodable byte as ``\xNN`` (and any other lone surrogate as ``\uDXXX``).
    """
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        try:
            return text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
        except UnicodeEncodeError:  # a lone surrogate that is no escaped byte
            return text.encode("utf-8", "backslashreplace").decode("utf-8")
    return text
