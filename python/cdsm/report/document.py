"""A small document model rendered to Markdown and to a self-contained HTML
page (figures embedded as base64, inline CSS), shared by every report.

A document is a title and a list of sections. The first section is the
headline (``id="headline"``): the page opens with it — in HTML it is the
first element of the body and holds the title (``<h1>``) and the answers —
then comes a table of contents linking every other section by its anchor.
Inline text knows ``**bold**``, ```code``` and ``[text](#anchor)``; text
from outside (a robot's name, a file name) goes in through :func:`literal`,
which backslash-escapes what either renderer would read as markup and turns
line breaks and other control characters into spaces, so it shows as
written and changes no structure. Nothing here knows a study: the reports
fill it.
"""

from __future__ import annotations

import base64
import html
import re
from typing import Dict, List, Optional

__all__ = ["Document", "HEADLINE", "literal"]

#: The id of the section every report opens with.
HEADLINE = "headline"

_LINK = re.compile(r"\[([^\]]+)\]\(#([A-Za-z0-9_-]+)\)")
#: characters Markdown or the HTML renderer's inline rules read as markup
_MARKUP = "\\`*_{}[]()#+-.!|<>~"
_ESCAPED = re.compile(r"\\([" + re.escape(_MARKUP) + r"])")
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")


def _cell(value) -> str:
    """A Markdown table cell: every pipe not escaped already (by :func:`literal`) escaped."""
    return re.sub(r"(?<!\\)((?:\\\\)*)\|", r"\1\\|", str(value))


def literal(text: str) -> str:
    """``text`` as inline text that shows as written in both renderers:
    markup characters backslash-escaped (CommonMark's escapes, which the HTML
    renderer undoes), line breaks and other control characters as spaces
    (a name cannot start a heading, a list or a table row)."""
    return "".join("\\" + c if c in _MARKUP else c for c in _CONTROL.sub(" ", str(text)))


class Document:
    """A titled document: :meth:`section` starts a section (the first one
    should be :data:`HEADLINE`); headings, paragraphs, lists, tables and
    figures go into the current one, in order."""

    def __init__(self, title: str):
        self.title = title
        self.sections: List[dict] = []

    def section(self, sid: str, title: str) -> None:
        """Start section ``sid`` (an anchor: letters, digits, ``-``, ``_``) titled ``title``."""
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]*", sid):
            raise ValueError(f"section id {sid!r}: letters, digits, - and _ only")
        if any(s["id"] == sid for s in self.sections):
            raise ValueError(f"section id {sid!r} used twice")
        self.sections.append(dict(id=sid, title=title, blocks=[]))

    def _add(self, block: tuple) -> None:
        if not self.sections:
            raise ValueError("start a section first")
        self.sections[-1]["blocks"].append(block)

    def h(self, level: int, text: str):
        """A sub-heading (level 3 or deeper) in the current section."""
        self._add(("h", max(int(level), 3), text))

    def p(self, text: str):
        self._add(("p", text))

    def ul(self, items: List[str]):
        self._add(("ul", list(items)))

    def table(self, header: List[str], rows: List[List[str]]):
        self._add(("table", header, rows))

    def fig(self, name: str, caption: str):
        """Figure ``name`` (a key of the ``pngs`` given to the renderers;
        left out when it was not drawn)."""
        self._add(("fig", name, caption))

    def _contents(self) -> List[dict]:
        return [s for s in self.sections if s["id"] != HEADLINE]

    # -- renderers --
    def markdown(self, figdir: str, pngs: Optional[Dict[str, bytes]] = None) -> str:
        """Markdown text: the title, the headline's blocks, the contents, then
        every section under ``<a id>`` anchors. Figures link to
        ``figdir/<name>.png`` (only those in ``pngs`` when given)."""
        out = [f"# {self.title}"]
        for s in self.sections:
            if s["id"] == HEADLINE:
                out += self._md_blocks(s["blocks"], figdir, pngs)
        if self._contents():
            out.append("## Contents")
            out.append("\n".join(f"{i + 1}. [{s['title']}](#{s['id']})" for i, s in enumerate(self._contents())))
        for s in self._contents():
            out.append(f"<a id=\"{s['id']}\"></a>\n\n## {s['title']}")
            out += self._md_blocks(s["blocks"], figdir, pngs)
        return "\n\n".join(out) + "\n"

    @staticmethod
    def _md_blocks(blocks, figdir: str, pngs) -> List[str]:
        out = []
        for b in blocks:
            if b[0] == "h":
                out.append("#" * b[1] + " " + b[2])
            elif b[0] == "p":
                out.append(b[1])
            elif b[0] == "ul":
                out.append("\n".join(f"- {i}" for i in b[1]))
            elif b[0] == "table":
                hdr, rows = b[1], b[2]
                lines = ["| " + " | ".join(_cell(h) for h in hdr) + " |", "|" + "---|" * len(hdr)]
                lines += ["| " + " | ".join(_cell(c) for c in r) + " |" for r in rows]
                out.append("\n".join(lines))
            elif b[0] == "fig" and (pngs is None or b[1] in pngs):
                out.append(f"![{b[2]}]({figdir}/{b[1]}.png)\n\n*{b[2]}*")
        return out

    def html(self, pngs: Dict[str, bytes], title: str) -> str:
        """A self-contained HTML page titled ``title``: the body's first
        element is the headline section (with the ``<h1>``), then the
        contents (``<nav id="contents">``), then each section; figures
        embedded from ``pngs`` ({name: PNG bytes}, as the run drew them:
        never read back from files another run may have replaced)."""
        def inline(t: str) -> str:
            # escaped characters (literal) wait as private-use code points while the markup is read
            t = _ESCAPED.sub(lambda m: chr(0xF0000 + ord(m.group(1))), t)
            t = html.escape(t)
            parts = t.split("**")
            t = "".join(f"<b>{s}</b>" if i % 2 else s for i, s in enumerate(parts))
            parts = t.split("`")
            t = "".join(f"<code>{s}</code>" if i % 2 else s for i, s in enumerate(parts))
            t = _LINK.sub(r"<a href='#\2'>\1</a>", t)
            return re.sub("[\U000F0000-\U000F007F]", lambda m: html.escape(chr(ord(m.group()) - 0xF0000)), t)

        def blocks(bs) -> List[str]:
            body = []
            for b in bs:
                if b[0] == "h":
                    body.append(f"<h{b[1]}>{inline(b[2])}</h{b[1]}>")
                elif b[0] == "p":
                    body.append(f"<p>{inline(b[1])}</p>")
                elif b[0] == "ul":
                    body.append("<ul>" + "".join(f"<li>{inline(i)}</li>" for i in b[1]) + "</ul>")
                elif b[0] == "table":
                    hdr = "".join(f"<th>{inline(str(h))}</th>" for h in b[1])
                    rows = "".join("<tr>" + "".join(f"<td>{inline(str(c))}</td>" for c in r) + "</tr>"
                                   for r in b[2])
                    body.append(f"<div class='tw'><table><thead><tr>{hdr}</tr></thead><tbody>{rows}</tbody>"
                                "</table></div>")
                elif b[0] == "fig":
                    png = pngs.get(b[1])
                    if png is None:
                        continue
                    data = base64.b64encode(png).decode("ascii")
                    body.append(f"<figure id='fig-{html.escape(b[1], quote=True)}'><img alt='"
                                f"{html.escape(b[2], quote=True)}' src='data:image/png;base64,{data}'>"
                                f"<figcaption>{inline(b[2])}</figcaption></figure>")
            return body

        out = []
        for s in self.sections:
            if s["id"] == HEADLINE:
                out.append(f"<section id='{HEADLINE}'><h1>{inline(self.title)}</h1>\n"
                           + "\n".join(blocks(s["blocks"])) + "\n</section>")
        if self._contents():
            out.append("<nav id='contents'><h2>Contents</h2><ol>" + "".join(
                f"<li><a href='#{s['id']}'>{inline(s['title'])}</a></li>" for s in self._contents()) + "</ol></nav>")
        for s in self._contents():
            out.append(f"<section id='{s['id']}'><h2>{inline(s['title'])}</h2>\n" + "\n".join(blocks(s["blocks"]))
                       + "\n</section>")
        css = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1200px;margin:1.2em auto;
padding:0 1.2em;color:#222;line-height:1.5}
h1{border-bottom:2px solid #1f5fbf;padding-bottom:.3em;margin-top:.2em;font-size:1.7em}
h2{margin-top:2em;border-bottom:1px solid #ccc}
#headline{background:#f4f7fc;border:1px solid #c9d6ee;border-radius:6px;padding:.2em 1.2em .6em}
#headline li{margin:.25em 0}
nav#contents ol{columns:2;column-gap:2em;margin:.3em 0}nav#contents h2{margin-top:1em}
table{border-collapse:collapse;margin:1em 0;font-size:.88em}th,td{border:1px solid #ccc;padding:.3em .6em;
text-align:left;vertical-align:top}th{background:#eef3fb}tr:nth-child(even) td{background:#fafafa}
.tw{overflow-x:auto}figure{margin:1.5em 0}img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.9em;color:#444;margin-top:.3em}code{background:#f3f3f3;padding:0 .2em}
"""
        return (f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
                f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
                f"<title>{html.escape(title)}</title><style>{css}</style></head><body>"
                + "\n".join(out) + "\n</body></html>\n")
