"""Readouts: text panels that are sent only when they change and grow in presenter view.

A readout is written in a small subset of Markdown (``**bold**``,
```` `code` ````, fenced code blocks, ``- `` lists, pipe tables (a header
row, a ``|---|---:|`` row whose colons align the columns, then the rows;
a ``|p| = 1`` line without such a rule row stays text),
blank lines between paragraphs, a line ending in two spaces or ``\\`` for
a line break) and shown
as HTML (viser's ``add_html``), so presenter view can scale its font; viser's
Markdown element is MDX, where ``{`` and ``<`` in a number readout would be
read as code. Everything is HTML-escaped before the markup is applied.
"""

from __future__ import annotations

import functools
import html
import math
import re
from typing import Any

__all__ = ["Readout", "markdown_to_html", "mode_table", "one_digit", "relation", "significant",
           "PRESENTER_FONT_SCALE", "PRESENTER_TABLE_SCALE"]

#: Font size of readouts in presenter view, relative to the panel's.
PRESENTER_FONT_SCALE = 1.45
#: Font size of a readout's tables in presenter view, relative to the readout's (1.45 x 0.7 = 1.0 of the
#: panel's, 16 % above a table outside presenter view): at the readout's size a table of six numeric columns
#: (the mode shapes', the bicycle's) is wider than the panel, and its right-hand columns were cut off. (The
#: panel itself is not widened: viser's plots lose their time axis when the panel's width changes.)
PRESENTER_TABLE_SCALE = 0.7

_BOLD = re.compile(r"\*\*(.+?)\*\*")
_CODE = re.compile(r"`([^`]+)`")
_ITALIC = re.compile(r"(?<![\w*])\*([^*\s][^*]*?)\*(?![\w*])")
_SUB = re.compile(r"&lt;sub&gt;(.+?)&lt;/sub&gt;")
_TABLE_RULE = re.compile(r"^\s*:?-{3,}:?\s*$")


def significant(x: float, digits: int = 4) -> str:
    """``x`` with ``digits`` significant digits, plain notation where it reads well."""
    if x == 0.0 or not math.isfinite(x):
        return f"{x:g}"
    if 1e-3 <= abs(x) < 1e5:
        decimals = max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))
        return f"{x:.{decimals}f}"
    return f"{x:.{digits - 1}e}"


def one_digit(x: float, floor: float = 0.0) -> str:
    """A drift or residual with one significant digit (``0`` when exactly zero); below ``floor`` (round-off)
    ``< floor``, so that a residual at round-off reads the same from frame to frame (not 4e-34, 0, 1e-17)."""
    if x == 0.0 or abs(x) < floor:
        return f"< {floor:.0e}" if floor > 0.0 else "0"
    return f"{abs(x):.0e}"


def relation(x: float, floor: float = 0.0) -> str:
    """``= 3e-12`` for a residual, ``< 1e-15`` at round-off (below ``floor``; :func:`one_digit`)."""
    text = one_digit(x, floor)
    return text if text.startswith("<") else f"= {text}"


@functools.lru_cache(maxsize=4096)
def _inline(text: str) -> str:
    text = html.escape(text, quote=False)
    text = _CODE.sub(r"<code>\1</code>", text)
    text = _BOLD.sub(r"<b>\1</b>", text)
    text = _ITALIC.sub(r"<i>\1</i>", text)
    text = _SUB.sub(r"<sub>\1</sub>", text)
    return text


def markdown_to_html(text: str, *, table_scale: float = 1.0) -> str:
    """HTML of the readout Markdown subset (see the module docstring)."""
    out: list[str] = []
    paragraph: list[str] = []
    items: list[str] = []
    lines = text.split("\n")
    i = 0

    def flush() -> None:
        if paragraph:
            out.append("<p style='margin:0 0 0.45em 0'>" + "".join(paragraph) + "</p>")
            paragraph.clear()
        if items:
            out.append("<ul style='margin:0 0 0.45em 0;padding-left:1.2em'>"
                       + "".join(f"<li>{x}</li>" for x in items) + "</ul>")
            items.clear()

    while i < len(lines):
        line = lines[i]
        if _is_table(lines, i):
            flush()
            rows = []
            while i < len(lines) and lines[i].lstrip().startswith("|"):
                rows.append(lines[i])
                i += 1
            out.append(_table(rows, table_scale))
            continue
        if line.startswith("```"):
            flush()
            block = []
            i += 1
            while i < len(lines) and not lines[i].startswith("```"):
                block.append(html.escape(lines[i], quote=False))
                i += 1
            out.append("<pre style='margin:0 0 0.45em 0;padding:0.3em 0.5em;background:#f3f4f6;"
                       "border-radius:4px;font-size:0.92em;overflow-x:auto'>" + "\n".join(block) + "</pre>")
        elif not line.strip():
            flush()
        elif line.lstrip().startswith("- "):
            if paragraph:
                flush()
            items.append(_inline(line.lstrip()[2:]))
        else:
            if items:
                flush()
            hard = line.endswith("  ") or line.endswith("\\")
            content = _inline(line.rstrip().rstrip("\\"))
            paragraph.append(content + ("<br/>" if hard else " "))
        i += 1
    flush()
    return "".join(out)


def _is_table(lines: list[str], i: int) -> bool:
    """A table starts at line ``i``: a row of cells, then a rule row of as many ``---`` cells.

    A line such as ``|p| = 1`` alone (a norm, not a table) stays text.
    """
    if not lines[i].lstrip().startswith("|") or i + 1 >= len(lines):
        return False
    rule = _cells(lines[i + 1])
    return (lines[i + 1].lstrip().startswith("|") and len(rule) == len(_cells(lines[i]))
            and all(_TABLE_RULE.match(cell) for cell in rule))


def _cells(row: str) -> list[str]:
    row = row.strip()
    if row.startswith("|"):
        row = row[1:]
    if row.endswith("|"):
        row = row[:-1]
    return [cell.strip() for cell in row.split("|")]


def _table(rows: list[str], scale: float = 1.0) -> str:
    """HTML of a pipe table: header row, ``|---|---:|`` rule (colons align), body rows; its font ``scale`` times
    the text's."""
    header = _cells(rows[0])
    aligns = ["right" if c.endswith(":") and not c.startswith(":") else
              "center" if c.startswith(":") and c.endswith(":") else "left" for c in _cells(rows[1])]
    body = rows[2:]
    pad = "padding:0.1em 0.45em"

    def cell(tag: str, text: str, k: int, extra: str = "") -> str:
        align = aligns[k] if k < len(aligns) else "left"
        return f"<{tag} style='{pad};text-align:{align}{extra}'>{_inline(text)}</{tag}>"

    head = "".join(cell("th", text, k, ";border-bottom:1px solid #c8ccd4;font-weight:600")
                   for k, text in enumerate(header))
    lines = ["<tr>" + "".join(cell("td", text, k) for k, text in enumerate(_cells(row))) + "</tr>" for row in body]
    size = "" if scale == 1.0 else f";font-size:{scale:g}em"
    return (f"<table style='border-collapse:collapse;margin:0 0 0.45em 0;font-variant-numeric:tabular-nums{size}'>"
            f"<thead><tr>{head}</tr></thead><tbody>{''.join(lines)}</tbody></table>")


class Readout:
    """A text panel of a scene (create with :meth:`rigidlab.app.scenes.base.Scene.add_readout`).

    Assigning :attr:`content` sends the text only if it changed, so a
    readout rewritten every frame with the same numbers costs nothing.
    """

    def __init__(self, handle: Any, *, presenter: bool = False) -> None:
        self.handle = handle
        self._text = ""
        self._presenter = presenter
        self._sent: str | None = None

    @property
    def content(self) -> str:
        return self._text

    @content.setter
    def content(self, text: str) -> None:
        text = str(text)
        if text == self._text and self._sent is not None:
            return  # unchanged: no rendering, nothing sent
        self._text = text
        self._send()

    @property
    def visible(self) -> bool:
        return bool(self.handle.visible)

    @visible.setter
    def visible(self, visible: bool) -> None:
        self.handle.visible = visible

    def set_presenter(self, on: bool) -> None:
        self._presenter = bool(on)
        self._send()

    def html(self) -> str:
        """The HTML sent for the current text."""
        size = f"{PRESENTER_FONT_SCALE:.2f}em" if self._presenter else "0.875em"
        return (f"<div class='rigidlab-readout' style='font-size:{size};line-height:1.4;"
                f"padding:0 0.75em 0.4em 0.75em'>"
                f"{markdown_to_html(self._text, table_scale=PRESENTER_TABLE_SCALE if self._presenter else 1.0)}</div>")

    def _send(self) -> None:
        out = self.html()
        if out != self._sent:
            self._sent = out
            self.handle.content = out


def mode_table(title: str, modes: Any, *, shape: tuple[str, Any] | None = None) -> str:
    """Markdown of modes: name, eigenvalue ``s`` (1/s), damped frequency ``Im s / 2 pi`` (Hz) and the time in
    which the amplitude halves (``Re s < 0``: ``ln 2 / -Re s``) or doubles, under ``title``.

    ``modes`` are ``(name, s)`` pairs; of a complex pair only the one with ``Im s > 0`` is a row.
    ``shape``: ``(header, texts)``, one more column (one text per mode, in the order of ``modes``).
    """
    head, texts = shape if shape is not None else ("", None)
    rows = [title, "", "| mode | s (1/s) | f (Hz) | ½ / ×2 in |" + (f" {head} |" if texts is not None else ""),
            "|---|---|---|---|" + ("---|" if texts is not None else "")]
    for i, (name, s) in enumerate(modes):
        s = complex(s)
        if s.imag < 0:
            continue  # the pair is one row
        when = (f"½ in {math.log(2) / -s.real:.2f} s" if s.real < 0 else
                f"×2 in {math.log(2) / s.real:.2f} s" if s.real > 0 else "neutral")
        eig = f"{s.real:+.3f} ± {s.imag:.3f}i" if s.imag > 0 else f"{s.real:+.3f}"
        freq = f"{s.imag / (2 * math.pi):.3f}" if s.imag > 0 else "–"
        rows.append(f"| {name} | {eig} | {freq} | {when} |" + (f" {texts[i]} |" if texts is not None else ""))
    return "\n".join(rows)
