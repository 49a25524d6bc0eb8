"""A small document model rendered to Markdown and to a self-contained HTML
page (figures embedded as base64, inline CSS), shared by every report."""

from __future__ import annotations

import base64
import html
from typing import Dict, List

from ..files import read_bytes

__all__ = ["Document"]


class Document:
    """Headings, paragraphs, lists, tables and figures, in order."""

    def __init__(self):
        self.blocks: List[tuple] = []

    def h(self, level: int, text: str):
        self.blocks.append(("h", level, text))

    def p(self, text: str):
        self.blocks.append(("p", text))

    def ul(self, items: List[str]):
        self.blocks.append(("ul", items))

    def table(self, header: List[str], rows: List[List[str]]):
        self.blocks.append(("table", header, rows))

    def fig(self, name: str, caption: str):
        self.blocks.append(("fig", name, caption))

    # -- renderers --
    def markdown(self, figdir: str) -> str:
        out = []
        for b in self.blocks:
            if b[0] == "h":
                out.append("#" * b[1] + " " + b[2])
            elif b[0] == "p":
                out.append(b[1])
            elif b[0] == "ul":
                out.append("\n".join(f"- {i}" for i in b[1]))
            elif b[0] == "table":
                hdr, rows = b[1], b[2]
                lines = ["| " + " | ".join(str(h).replace("|", "\\|") for h in hdr) + " |", "|" + "---|" * len(hdr)]
                lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |" for r in rows]
                out.append("\n".join(lines))
            elif b[0] == "fig":
                out.append(f"![{b[2]}]({figdir}/{b[1]}.png)\n\n*{b[2]}*")
        return "\n\n".join(out) + "\n"

    def html(self, pngs: Dict[str, str], title: str) -> str:
        def inline(t: str) -> str:
            t = html.escape(t)
            # **bold** and `code`
            parts = t.split("**")
            t = "".join(f"<b>{s}</b>" if i % 2 else s for i, s in enumerate(parts))
            parts = t.split("`")
            return "".join(f"<code>{s}</code>" if i % 2 else s for i, s in enumerate(parts))

        body = []
        for b in self.blocks:
            if b[0] == "h":
                body.append(f"<h{b[1]}>{inline(b[2])}</h{b[1]}>")
            elif b[0] == "p":
                body.append(f"<p>{inline(b[1])}</p>")
            elif b[0] == "ul":
                body.append("<ul>" + "".join(f"<li>{inline(i)}</li>" for i in b[1]) + "</ul>")
            elif b[0] == "table":
                hdr = "".join(f"<th>{inline(h)}</th>" for h in b[1])
                rows = "".join("<tr>" + "".join(f"<td>{inline(str(c))}</td>" for c in r) + "</tr>"
                               for r in b[2])
                body.append(f"<div class='tw'><table><thead><tr>{hdr}</tr></thead><tbody>{rows}</tbody></table></div>")
            elif b[0] == "fig":
                path = pngs.get(b[1])
                if path is None:
                    continue
                data = base64.b64encode(read_bytes(path, "figure")).decode("ascii")
                body.append(f"<figure><img alt='{html.escape(b[2], quote=True)}' "
                            f"src='data:image/png;base64,{data}'><figcaption>{inline(b[2])}</figcaption></figure>")
        css = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1200px;margin:2em auto;
padding:0 1.2em;color:#222;line-height:1.5}
h1{border-bottom:2px solid #1f5fbf;padding-bottom:.3em}h2{margin-top:2em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:1em 0;font-size:.88em}th,td{border:1px solid #ccc;padding:.3em .6em;
text-align:left;vertical-align:top}th{background:#eef3fb}tr:nth-child(even) td{background:#fafafa}
.tw{overflow-x:auto}figure{margin:1.5em 0}img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.9em;color:#444;margin-top:.3em}code{background:#f3f3f3;padding:0 .2em}
"""
        return (f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
                f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
                f"<title>{html.escape(title)}</title><style>{css}</style></head><body>\n"
                + "\n".join(body) + "\n</body></html>\n")
