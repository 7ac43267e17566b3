"""Building blocks of a self-contained HTML report: figures embedded as base64 PNG, tables."""
from __future__ import annotations

import base64
import html
import io
import re
from collections.abc import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (backend must be chosen first)
import pandas as pd  # noqa: E402

STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
h1, h2, h3 { color: #123; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.5em; text-align: right; }
th { background: #eef; }
td.text, th.text { text-align: left; }
figure { margin: 1em 0; max-width: 100%; }
figure img, figure svg { max-width: 100%; height: auto; }
div.table { max-width: 100%; overflow-x: auto; }
nav.toc { font-size: 0.9em; border: 1px solid #ccd; padding: 0.5em 1em; margin: 1em 0; }
nav.toc li { margin: 0.1em 0; }
details > summary { cursor: pointer; color: #123; }
figcaption { font-size: 0.85em; color: #555; }
.note { font-size: 0.9em; color: #444; }
"""

#: Tables longer than this are folded (``<details>``) so the page stays readable.
FOLD_ROWS = 25


def figure_html(fig: plt.Figure, caption: str, vector: bool = False) -> str:
    """Embed a matplotlib figure, then close it: as inline SVG for line art (``vector``), else as a
    PNG data URI. Either scales to the page width."""
    buffer = io.BytesIO()
    if vector:
        fig.savefig(buffer, format="svg", bbox_inches="tight")
        plt.close(fig)
        svg = buffer.getvalue().decode()
        svg = svg[svg.index("<svg"):]  # drop the XML prologue and doctype inside the HTML
        return f"<figure>{svg}<figcaption>{html.escape(caption)}</figcaption></figure>"
    fig.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    data = base64.b64encode(buffer.getvalue()).decode()
    return (
        f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{html.escape(caption)}</figcaption></figure>"
    )


def table_html(frame: pd.DataFrame, float_format: str = "{:.4g}", cell_style: Sequence[Sequence[str]] | None = None,
               css_class: str = "") -> str:
    """An HTML table of a data frame; optional per-cell inline styles (same shape as the frame) and class."""
    head = "".join(f'<th class="text">{html.escape(str(c))}</th>' for c in frame.columns)
    rows = []
    for i, (_, row) in enumerate(frame.iterrows()):
        cells = []
        for j, value in enumerate(row):
            style = f' style="{cell_style[i][j]}"' if cell_style is not None and cell_style[i][j] else ""
            if isinstance(value, float):
                cells.append(f"<td{style}>{float_format.format(value)}</td>")
            else:
                cells.append(f'<td class="text"{style}>{html.escape(str(value))}</td>')
        rows.append("<tr>" + "".join(cells) + "</tr>")
    klass = f" class='{css_class}'" if css_class else ""
    table = f"<div class='table'><table{klass}><tr>{head}</tr>{''.join(rows)}</table></div>"
    if len(rows) > FOLD_ROWS:
        return f"<details><summary>table of {len(rows)} rows</summary>{table}</details>"
    return table


def page(title: str, sections: Sequence[str]) -> str:
    """A whole HTML document, with a table of contents of its h2 sections."""
    body = "\n".join(sections)
    entries = []

    def anchor(match: re.Match[str]) -> str:
        k = len(entries)
        entries.append(match.group(1))
        return f"<h2 id='s{k}'>{match.group(1)}</h2>"

    body = re.sub(r"<h2>(.*?)</h2>", anchor, body)
    toc = "<nav class='toc'><b>Contents</b><ol>" + "".join(f"<li><a href='#s{k}'>{e}</a></li>" for k, e in enumerate(entries)) + "</ol></nav>"
    body = toc + "\n" + body
    return (
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>{STYLE}</style></head><body><h1>{html.escape(title)}</h1>\n{body}\n</body></html>"
    )
