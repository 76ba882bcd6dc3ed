"""A small report builder that renders the same content as Markdown and HTML.

Numbers enter a report only through :meth:`Report.table` and
:meth:`Report.value` from objects the library returned, never typed by hand;
:meth:`Report.values` keeps every number so a test can compare the report with
the library's results.
"""

from __future__ import annotations

import dataclasses
import html
import json
import math
from pathlib import Path

import pandas as pd


@dataclasses.dataclass
class _Block:
    kind: str
    content: object
    extra: object = None


def _fmt(x, digits=3):
    if isinstance(x, (int,)) and not isinstance(x, bool):
        return str(x)
    if isinstance(x, float):
        if math.isnan(x):
            return "–"
        return f"{x:.{digits}f}"
    return str(x)


class Report:
    """Collects headings, paragraphs, tables and figures; writes ``.md`` and ``.html``."""

    def __init__(self, title: str):
        self.title = title
        self.blocks: list[_Block] = []
        self.numbers: dict[str, object] = {}

    def heading(self, text: str, level: int = 2):
        self.blocks.append(_Block("heading", text, level))

    def paragraph(self, text: str):
        self.blocks.append(_Block("paragraph", text))

    def bullets(self, items):
        self.blocks.append(_Block("bullets", list(items)))

    def code(self, text: str):
        self.blocks.append(_Block("code", text))

    def value(self, key: str, number, digits: int = 3) -> str:
        """Record ``number`` under ``key`` and return its formatted text for prose."""
        self.numbers[key] = number
        return _fmt(number, digits)

    def table(self, key: str, df: pd.DataFrame, caption: str = "", digits: int = 3):
        """Add a table; its numbers are recorded under ``key``."""
        self.numbers[key] = json.loads(df.to_json(orient="split"))
        self.blocks.append(_Block("table", df, (caption, digits)))

    def figure(self, path, caption: str):
        self.blocks.append(_Block("figure", Path(path), caption))

    # ----------------------------------------------------------------- render
    def to_markdown(self, relative_to: Path) -> str:
        out = [f"# {self.title}", ""]
        for b in self.blocks:
            if b.kind == "heading":
                out += ["#" * b.extra + " " + b.content, ""]
            elif b.kind == "paragraph":
                out += [b.content, ""]
            elif b.kind == "bullets":
                out += [f"- {item}" for item in b.content] + [""]
            elif b.kind == "code":
                out += ["```", b.content, "```", ""]
            elif b.kind == "table":
                caption, digits = b.extra
                df = b.content
                cols = [str(df.index.name or "")] + [str(c) for c in df.columns]
                out.append("| " + " | ".join(cols) + " |")
                out.append("|" + "---|" * len(cols))
                for idx, row in df.iterrows():
                    out.append("| " + " | ".join([str(idx)] + [_fmt(v, digits) for v in row]) + " |")
                if caption:
                    out += ["", f"*{caption}*"]
                out.append("")
            elif b.kind == "figure":
                rel = _rel(b.content, relative_to)
                out += [f"![{b.extra}]({rel})", "", f"*{b.extra}*", ""]
        return "\n".join(out)

    def to_html(self, relative_to: Path) -> str:
        e = html.escape
        out = [
            "<!DOCTYPE html><html><head><meta charset='utf-8'>",
            f"<title>{e(self.title)}</title>",
            "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;line-height:1.45}"
            "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:3px 8px;"
            "text-align:right}th{background:#eee}img{max-width:100%}figcaption{font-style:italic;color:#444}"
            "pre{background:#f4f4f4;padding:0.6em;overflow-x:auto}</style></head><body>",
            f"<h1>{e(self.title)}</h1>",
        ]
        for b in self.blocks:
            if b.kind == "heading":
                out.append(f"<h{b.extra}>{e(b.content)}</h{b.extra}>")
            elif b.kind == "paragraph":
                out.append(f"<p>{e(b.content)}</p>")
            elif b.kind == "bullets":
                out.append("<ul>" + "".join(f"<li>{e(str(i))}</li>" for i in b.content) + "</ul>")
            elif b.kind == "code":
                out.append(f"<pre>{e(b.content)}</pre>")
            elif b.kind == "table":
                caption, digits = b.extra
                df = b.content
                rows = [
                    "<tr><th>"
                    + e(str(df.index.name or ""))
                    + "</th>"
                    + "".join(f"<th>{e(str(c))}</th>" for c in df.columns)
                    + "</tr>"
                ]
                for idx, row in df.iterrows():
                    cells = "".join(f"<td>{e(_fmt(v, digits))}</td>" for v in row)
                    rows.append(f"<tr><th>{e(str(idx))}</th>{cells}</tr>")
                cap = f"<caption>{e(caption)}</caption>" if caption else ""
                out.append(f"<table>{cap}{''.join(rows)}</table>")
            elif b.kind == "figure":
                rel = _rel(b.content, relative_to)
                out.append(f"<figure><img src='{e(rel)}'><figcaption>{e(b.extra)}</figcaption></figure>")
        out.append("</body></html>")
        return "\n".join(out)

    def write(self, folder) -> dict[str, Path]:
        """Write ``report.md``, ``report.html`` and ``report_numbers.json`` into ``folder``."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        paths = {
            "markdown": folder / "report.md",
            "html": folder / "report.html",
            "numbers": folder / "report_numbers.json",
        }
        paths["markdown"].write_text(self.to_markdown(folder), encoding="utf-8")
        paths["html"].write_text(self.to_html(folder), encoding="utf-8")
        paths["numbers"].write_text(json.dumps(self.numbers, indent=1, default=_json_default), encoding="utf-8")
        return paths


def _rel(path: Path, folder: Path) -> str:
    try:
        return str(Path(path).resolve().relative_to(Path(folder).resolve()))
    except ValueError:
        return str(path)


def _json_default(o):
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)
