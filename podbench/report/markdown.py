"""The Markdown of podbench's texts (claims' notes and remarks, scenario descriptions,
docstrings) as HTML for the self-contained report page.

A small, dependency-free subset of CommonMark and GitHub's tables, the subset the texts use:

* paragraphs (lines joined; a blank line ends one);
* ``#`` … ``######`` headings (shifted down by ``heading_offset`` to sit under the page's own);
* bullet (``*``, ``-``, ``+``) and ordered (``1.``, ``1)``) lists, nested by indentation, which
  may interrupt a paragraph (``Checks:`` followed by ``  * …`` is a list, as on GitHub);
* pipe tables (a header row, a ``|---|:---:|`` delimiter row, body rows; cell alignment
  from the colons; ``\\|`` is a literal pipe), wrapped in a horizontally scrolling ``div`` so
  a wide table is never cut;
* fenced code blocks (````` ``` `````), block quotes (``>``);
* inline: code spans (single or double backticks), ``**strong**``, ``*emphasis*``, and links
  ``[text](#anchor)`` (a link to anything but an anchor of the page is written as its text
  followed by the target in ``<code>``: the page loads nothing and links nowhere else).

Everything else is escaped: the output never carries markup from the text. A line that
merely starts with ``|`` (``|u₁ᵀφ₂| = 0.29``) is prose unless a delimiter row follows it.
"""

from __future__ import annotations

import html
import re

__all__ = ["markdown_to_html", "inline_html"]

_BULLET = re.compile(r"^( {0,12})([*+-]|\d{1,9}[.)])( +|$)(.*)$")
_HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
_FENCE = re.compile(r"^ {0,3}(```+|~~~+)\s*([\w+-]*)\s*$")
_DELIM = re.compile(r"^\s*\|?\s*:?-+:?\s*(\|\s*:?-+:?\s*)*\|?\s*$")
_QUOTE = re.compile(r"^ {0,3}> ?(.*)$")


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def inline_html(text: str) -> str:
    """One line of Markdown inline syntax as HTML (code spans, strong, emphasis, links)."""
    parts = re.split(r"(``.+?``|`[^`]+`)", text)
    out = []
    for p in parts:
        if len(p) > 1 and p.startswith("`") and p.endswith("`"):
            out.append(f"<code>{_e(' '.join(p.strip('`').split()))}</code>")
            continue
        s = _e(re.sub(r"\s+", " ", p))
        s = re.sub(r"\[([^\]]+)\]\(([^)\s]+)\)", _link, s)
        s = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", s)
        s = re.sub(r"(?<![\w*])\*(?!\s)(.+?)(?<!\s)\*(?![\w*])", r"<em>\1</em>", s)
        out.append(s)
    return "".join(out)


def _link(m: re.Match) -> str:
    text, target = m.group(1), m.group(2)
    if target.startswith("#"):
        return f'<a href="{target}">{text}</a>'
    return f"{text} (<code>{target}</code>)"


def _split_row(line: str) -> list[str]:
    s = line.strip()
    if s.startswith("|"):
        s = s[1:]
    if s.endswith("|") and not s.endswith("\\|"):
        s = s[:-1]
    cells = re.split(r"(?<!\\)\|", s)
    return [c.strip().replace("\\|", "|") for c in cells]


def _table(lines: list[str]) -> str:
    head = _split_row(lines[0])
    align = []
    for d in _split_row(lines[1]):
        left, right = d.startswith(":"), d.endswith(":")
        align.append("center" if left and right else "right" if right else
                     "left" if left else "")
    n = len(head)

    def cell(tag: str, text: str, i: int) -> str:
        a = align[i] if i < len(align) and align[i] else "left"
        return f'<{tag} class="md" style="text-align:{a}">{inline_html(text)}</{tag}>'

    rows = []
    for ln in lines[2:]:
        cells = (_split_row(ln) + [""] * n)[:n]
        rows.append("<tr>" + "".join(cell("td", c, i) for i, c in enumerate(cells)) + "</tr>")
    return ('<div class="scroll"><table class="md"><thead><tr>'
            + "".join(cell("th", c, i) for i, c in enumerate(head))
            + f"</tr></thead><tbody>{''.join(rows)}</tbody></table></div>")


def _is_table_start(lines: list[str], i: int) -> bool:
    return ("|" in lines[i] and i + 1 < len(lines) and "|" in lines[i + 1]
            and bool(_DELIM.match(lines[i + 1]))
            and len(_split_row(lines[i])) == len(_split_row(lines[i + 1])))


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def _list(lines: list[str], i: int, offset: int) -> tuple[str, int]:
    """The list starting at ``lines[i]``; returns its HTML and the index after it."""
    m = _BULLET.match(lines[i])
    assert m is not None
    base = len(m.group(1))
    ordered = m.group(2)[0].isdigit()
    items: list[list[str]] = []
    while i < len(lines):
        ln = lines[i]
        m = _BULLET.match(ln)
        if m and len(m.group(1)) == base and m.group(2)[0].isdigit() == ordered:
            items.append([m.group(4)])
        elif not ln.strip():
            nxt = next((x for x in lines[i + 1:] if x.strip()), "")
            if _indent(nxt) <= base and not (_BULLET.match(nxt) and _indent(nxt) == base):
                break
            items[-1].append("")
        elif _indent(ln) > base:
            items[-1].append(ln[min(_indent(ln), base + 2):])
        else:
            break
        i += 1
    tag = "ol" if ordered else "ul"
    body = []
    for it in items:
        inner = _blocks(it, offset)
        if inner.startswith("<p>") and inner.count("<p>") == 1:  # a tight item
            inner = inner[3:].replace("</p>", "", 1)
        body.append(f"<li>{inner}</li>")
    return f"<{tag}>{''.join(body)}</{tag}>", i


def _starts_block(lines: list[str], i: int) -> bool:
    ln = lines[i]
    return bool(_HEADING.match(ln) or _FENCE.match(ln) or _QUOTE.match(ln)
                or (_BULLET.match(ln) and _BULLET.match(ln).group(4).strip())  # type: ignore[union-attr]
                or _is_table_start(lines, i))


def _blocks(lines: list[str], offset: int) -> str:
    out: list[str] = []
    i = 0
    while i < len(lines):
        ln = lines[i]
        if not ln.strip():
            i += 1
        elif m := _FENCE.match(ln):
            j = i + 1
            while j < len(lines) and not lines[j].strip().startswith(m.group(1)):
                j += 1
            out.append(f"<pre><code>{_e(chr(10).join(lines[i + 1:j]))}</code></pre>")
            i = j + 1
        elif m := _HEADING.match(ln):
            level = min(6, len(m.group(1)) + offset)
            out.append(f"<h{level}>{inline_html(m.group(2))}</h{level}>")
            i += 1
        elif _QUOTE.match(ln):
            j = i
            inner = []
            while j < len(lines) and (q := _QUOTE.match(lines[j])):
                inner.append(q.group(1))
                j += 1
            out.append(f"<blockquote>{_blocks(inner, offset)}</blockquote>")
            i = j
        elif _is_table_start(lines, i):
            j = i + 2
            while j < len(lines) and lines[j].strip() and "|" in lines[j]:
                j += 1
            out.append(_table(lines[i:j]))
            i = j
        elif _BULLET.match(ln) and _BULLET.match(ln).group(4).strip():  # type: ignore[union-attr]
            html_, i = _list(lines, i, offset)
            out.append(html_)
        else:
            para = [ln.strip()]
            i += 1
            while i < len(lines) and lines[i].strip() and not _starts_block(lines, i):
                para.append(lines[i].strip())
                i += 1
            out.append(f"<p>{inline_html(' '.join(para))}</p>")
    return "\n".join(out)


def markdown_to_html(text: str, heading_offset: int = 0) -> str:
    """``text`` (Markdown, see the module docstring) as HTML; headings ``#`` become
    ``<h{1 + heading_offset}>``."""
    lines = text.expandtabs(4).strip("\n").split("\n")
    return _blocks(lines, heading_offset)
