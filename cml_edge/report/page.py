"""report.html: the report as one self-contained page.

The figures are embedded (PNG as data URIs), the style and the table-sorting script are
inline, and the page's content security policy forbids every other source, so it opens
offline and fetches nothing. A click on a column header sorts the table by the cells' raw
values (``data-value``), not by their formatted text.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

from cml_edge.report.sections import Section
from cml_edge.report.tables import Table, to_html

POLICY = ("default-src 'none'; img-src data:; style-src 'unsafe-inline'; "
          "script-src 'unsafe-inline'")
"""Nothing but the page itself and its embedded images."""

STYLE = """
body{font:15px/1.45 system-ui,sans-serif;margin:0 auto;max-width:1200px;padding:0 16px;
color:#1b1f24}
h1{margin-top:24px}h2{border-bottom:1px solid #d0d7de;padding-bottom:4px;margin-top:36px}
nav a{margin-right:12px}p.made-by{color:#57606a;font-size:13px}
code{background:#f3f4f6;padding:1px 4px;border-radius:3px;font-size:13px}
div.scroll{overflow-x:auto;margin:8px 0 16px}
table{border-collapse:collapse;font-size:13px}
th,td{border:1px solid #d0d7de;padding:3px 8px;text-align:right;white-space:nowrap}
th[scope=row],td.text{text-align:left}td[data-verdict]{white-space:normal;min-width:7em}
td small{color:#424a53}
thead th{background:#f6f8fa;cursor:pointer;position:sticky;top:0;text-align:center}
thead th[aria-sort=ascending]::after{content:" \\25B2"}
thead th[aria-sort=descending]::after{content:" \\25BC"}
td.v-survives{background:#dcf5dc}td.v-degrades{background:#fdebc8}
td.v-fails{background:#f8d0d0}
td.changed{outline:2px solid #bf8700;outline-offset:-2px;font-weight:600}
figure{margin:16px 0}figure img{max-width:100%}figcaption{color:#57606a;font-size:13px}
"""

SCRIPT = """
document.querySelectorAll("table.sortable").forEach(function (table) {
  table.querySelectorAll("thead th").forEach(function (th, col) {
    th.addEventListener("click", function () {
      var down = th.getAttribute("aria-sort") === "ascending";
      table.querySelectorAll("thead th").forEach(function (h) {
        h.removeAttribute("aria-sort");
      });
      th.setAttribute("aria-sort", down ? "descending" : "ascending");
      var body = table.tBodies[0];
      var rows = Array.prototype.slice.call(body.rows);
      function key(row) {
        var cell = row.cells[col];
        var v = cell.getAttribute("data-value");
        return v === null || v === "" ? cell.textContent : parseFloat(v);
      }
      rows.sort(function (a, b) {  // numbers before words (n/a), either way
        var x = key(a), y = key(b), nx = typeof x === "number", ny = typeof y === "number";
        if (nx !== ny) { return nx ? -1 : 1; }
        var c = nx ? x - y : String(x).localeCompare(String(y));
        return down ? -c : c;
      });
      rows.forEach(function (row) { body.appendChild(row); });
    });
  });
});
"""


def prose(text: str) -> str:
    """A paragraph of the report's prose as HTML: ``code`` and **strong**, escaped."""
    out = html.escape(text, quote=False)
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    return re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", out)


def section_html(section: Section) -> str:
    """One section: its title, what made it, its paragraphs and tables."""
    parts = [f'<section id="{section.key}"><h2>{html.escape(section.title)}</h2>',
             f'<p class="made-by">{prose(section.made_by)}</p>']
    for block in section.blocks:
        parts.append(to_html(block) if isinstance(block, Table) else f"<p>{prose(block)}</p>")
    return "".join(parts) + "</section>"


def figures_html(folder: Path, figures: dict[str, str]) -> str:
    """The figures, each embedded as a data URI."""
    items = []
    for title, name in figures.items():
        data = base64.b64encode((folder / name).read_bytes()).decode()
        items.append(f'<figure><img src="data:image/png;base64,{data}" '
                     f'alt="{html.escape(title)}"><figcaption>{html.escape(title)} '
                     f"({html.escape(name)})</figcaption></figure>")
    return ('<section id="figures"><h2>Figures</h2><p class="made-by">Drawn from '
            "report.json alone (the PNG files beside this page).</p>" + "".join(items)
            + "</section>")


def page(title: str, intro: list[str], sections: list[Section], folder: Path,
         figures: dict[str, str]) -> str:
    """The whole page: title, a line of contents, ``intro`` paragraphs, the sections and
    the figures (read from ``folder``)."""
    nav = "".join(f'<a href="#{s.key}">{html.escape(s.title.split(":")[0])}</a>'
                  for s in sections) + '<a href="#figures">Figures</a>'
    body = "".join(section_html(s) for s in sections)
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
            f'<meta http-equiv="Content-Security-Policy" content="{POLICY}">'
            f'<meta name="viewport" content="width=device-width,initial-scale=1">'
            f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
            f"<h1>{html.escape(title)}</h1>"
            + "".join(f"<p>{prose(p)}</p>" for p in intro)
            + f"<nav>{nav}</nav>{body}{figures_html(folder, figures)}"
            f"<script>{SCRIPT}</script></body></html>\n")
