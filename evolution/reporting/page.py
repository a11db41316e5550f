"""``report/index.html``: the whole report on one page a researcher opens in a browser.

One HTML file beside the figures it shows: the experiments compared (and what was left out),
every figure, every table of ``summary.md`` (the same :class:`~evolution.reporting.tables.Section`
objects, so the page and the Markdown never disagree), the commands that make the results and
the report again (:mod:`evolution.reporting.reproduce`), and every experiment's stored settings.
Images and links are relative (``fitness_over_births.png``), so the page opens from the file
system, and the report folder can be moved or zipped whole. The page holds no script and loads
nothing from the network: opening it runs no code.
"""

from __future__ import annotations

import html
import math
import struct
from collections.abc import Mapping, Sequence
from pathlib import Path

from evolution.experiments.app.api import flat_keys
from evolution.experiments.store.database import DB_NAME, Store, package_version
from evolution.reporting.data import Included
from evolution.reporting.figures import FIGURE_DPI
from evolution.reporting.reproduce import Command
from evolution.reporting.tables import Cell, Section

__all__ = ["FIGURE_TITLES", "PAGE_NAME", "SETTINGS_TABLE", "write_page"]

PAGE_NAME = "index.html"
"""The page's file name in the report folder."""

SETTINGS_TABLE = "settings"
"""The ``id`` of the settings table (one row per config key, one column per experiment)."""

FIGURE_TITLES = {
    "fitness_over_births": "Fitness over births",
    "final_fitness": "Fitness of the compared populations",
    "diversity_over_births": "Diversity over births",
    "final_diversity": "Diversity of the compared populations",
    "lost_robots": "Robots lost",
    "curve_tests": "Whole curves at equal births",
    "learning_gain": "Infancy learning",
    "optimism": "Optimism of a single evaluation",
}
"""Headings of the figures on the page, by file stem (others show their stem)."""

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 0 auto; max-width: 1200px; padding: 1em 2em;
       color: #111; background: #fff; line-height: 1.45; }
h1 { font-size: 1.6em; } h2 { margin-top: 2em; border-bottom: 1px solid #ccc; }
nav a { margin-right: 1em; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #333; }
.scroll { overflow-x: auto; max-width: 100%; margin: 0.8em 0;
  background: linear-gradient(to right, #fff 30%, rgba(255,255,255,0)) left / 2em 100%,
    linear-gradient(to left, #fff 30%, rgba(255,255,255,0)) right / 2em 100%,
    radial-gradient(farthest-side at 0 50%, rgba(0,0,0,.25), rgba(0,0,0,0)) left / .8em 100%,
    radial-gradient(farthest-side at 100% 50%, rgba(0,0,0,.25), rgba(0,0,0,0)) right / .8em 100%;
  background-repeat: no-repeat; background-attachment: local, local, scroll, scroll; }
table { border-collapse: collapse; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: right; }
th { background: #f0f0f0; white-space: normal; vertical-align: bottom; }
td.text, th.text { text-align: left; }
td.text { overflow-wrap: anywhere; min-width: 6em; }
td.num { white-space: nowrap; }
tr.differs td { background: #fff4d6; }
pre { background: #f6f6f6; padding: 0.8em; overflow-x: auto; }
code { font-size: 0.95em; }
"""


def _inline(text: str) -> str:
    """Escaped text with ``code`` spans."""
    parts = html.escape(text).split("`")
    return "".join(f"<code>{p}</code>" if i % 2 else p for i, p in enumerate(parts))


def _cell(value: Cell) -> tuple[str, str]:
    """A cell's text and class (numbers right-aligned, text left)."""
    if isinstance(value, float):
        return ("-" if math.isnan(value) else f"{value:.4g}"), "num"
    if isinstance(value, int):
        return str(value), "num"
    return str(value), "text"


def _header(column: str) -> str:
    """A column name that may wrap after each underscore (``final_<wbr>fitness_<wbr>mean``)."""
    return html.escape(column).replace("_", "_<wbr>")


def _table(name: str, columns: Sequence[str], rows: Sequence[Mapping[str, Cell]],
           row_classes: Sequence[str] = ()) -> list[str]:
    """A table in a box of the page's width, never cut at its edge.

    Its headers (after each underscore) and text cells wrap, and what is still wider scrolls
    sideways inside the box, whose edges cast a shadow where there is more.
    """
    kinds = [_cell(rows[0][c])[1] if rows else "text" for c in columns]
    head = "".join(f'<th scope="col" class="{kind}">{_header(c)}</th>'
                   for c, kind in zip(columns, kinds, strict=True))
    lines = [f'<div class="scroll" role="region" tabindex="0" aria-label="{html.escape(name)}">',
             f'<table id="{html.escape(name)}">',
             f"<thead><tr>{head}</tr></thead>", "<tbody>"]
    for k, row in enumerate(rows):
        cells = []
        for c in columns:
            text, kind = _cell(row[c])
            cells.append(f'<td class="{kind}">{html.escape(text)}</td>')
        css = f' class="{row_classes[k]}"' if k < len(row_classes) and row_classes[k] else ""
        lines.append(f"<tr{css}>{''.join(cells)}</tr>")
    return [*lines, "</tbody>", "</table>", "</div>"]


def _anchor(part: Section) -> str:
    """The id of a section's block (its table's id is the section's name)."""
    return f"section-{part.name}"


def _short(title: str) -> str:
    """A section's title for the navigation bar: up to its first colon or parenthesis."""
    return title.split(":")[0].split(" (")[0]


def _section(part: Section) -> list[str]:
    lines = [f'<section id="{_anchor(part)}">', f"<h2>{html.escape(part.title)}</h2>"]
    items: list[str] = []
    for paragraph in part.text:
        if paragraph.startswith("- "):
            items.append(f"<li>{_inline(paragraph[2:])}</li>")
            continue
        if items:
            lines += ["<ul>", *items, "</ul>"]
            items = []
        lines.append(f"<p>{_inline(paragraph)}</p>")
    if items:
        lines += ["<ul>", *items, "</ul>"]
    if part.columns:
        lines += (_table(part.name, part.columns, part.rows) if part.rows
                  else [f"<p>{html.escape(part.empty)}</p>"])
    return [*lines, "</section>"]


def _figures(out_dir: Path, figures: Sequence[Path]) -> list[str]:
    """Each figure once: its PNG (else SVG) shown, every format linked."""
    stems = list(dict.fromkeys(p.stem for p in figures))
    lines = ['<section id="figures">', "<h2>Figures</h2>",
             "<p>Each figure's caption is drawn inside it; every file is in this folder.</p>"]
    for stem in stems:
        files = [p for p in figures if p.stem == stem]
        shown = next((p for p in files if p.suffix in (".png", ".svg")), None)
        title = FIGURE_TITLES.get(stem, stem)
        links = " ".join(f'<a href="{html.escape(p.relative_to(out_dir).as_posix())}">'
                         f"{p.suffix[1:].upper()}</a>" for p in files)
        lines.append(f'<figure id="figure-{html.escape(stem)}">')
        if shown is not None:
            lines.append(f'<img src="{html.escape(shown.relative_to(out_dir).as_posix())}" '
                         f'alt="{html.escape(title)}"{_shown_size(shown)}>')
        lines += [f"<figcaption><strong>{html.escape(title)}</strong> "
                  f"({html.escape(stem)}: {links})</figcaption>", "</figure>"]
    return [*lines, "</section>"]


CSS_PX_PER_INCH = 96
"""A browser's pixels per inch: a figure shown at its size in inches."""


def _shown_size(image: Path) -> str:
    """``width``/``height`` attributes showing a PNG figure at its size in inches.

    Every figure's text has one size in points (:data:`~evolution.reporting.style.TEXT_SIZE`):
    shown at ``FIGURE_DPI`` pixels per inch each, a wide figure would be shrunk to the page and
    its text with it, a narrow one not. At :data:`CSS_PX_PER_INCH` they read alike (the widest
    is shrunk a little where the page is narrower). Empty for an SVG (its own size is in
    inches) or a file that is not a PNG.
    """
    if image.suffix != ".png":
        return ""
    with open(image, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return ""
    width, height = struct.unpack(">II", head[16:24])
    scale = CSS_PX_PER_INCH / FIGURE_DPI
    return f' width="{round(width * scale)}" height="{round(height * scale)}"'


def _commands(commands: Sequence[Command]) -> list[str]:
    lines = ['<section id="reproduce">', "<h2>How to reproduce</h2>",
             "<p>From the folder this report was made in, these commands make the results and "
             "this report again (the same numbers: every run is seeded). They are read from "
             "the stored settings; options that only change how runs execute (workers, Ray) "
             "are left out.</p>", "<ol>"]
    for c in commands:
        lines.append(f"<li>{html.escape(c.what)}:<pre><code>{html.escape(c.line)}</code></pre>"
                     "</li>")
    return [*lines, "</ol>", "</section>"]


def _settings(included: Included) -> list[str]:
    """Every stored config key (rows) of every experiment (columns); differing rows marked."""
    experiments = included.experiments
    flat = [flat_keys(e.config) for e in experiments]
    versions = []
    for e in experiments:
        with Store.open(e.path / DB_NAME) as store:
            versions.append(store.meta().get("package_version", "unknown"))
    keys = sorted({k for f in flat for k in f})
    columns = ["setting", *[e.label for e in experiments]]
    rows: list[dict[str, Cell]] = [{"setting": "revolve-env version that wrote it",
                                    **{e.label: v for e, v in zip(experiments, versions,
                                                                  strict=True)}}]
    rows += [{"setting": k, **{e.label: _shown(f.get(k)) for e, f in zip(experiments, flat,
                                                                          strict=True)}}
             for k in keys]
    differs = ["differs" if len({str(r[c]) for c in columns[1:]}) > 1 else "" for r in rows]
    return ['<section id="section-settings">', "<h2>Run settings</h2>",
            "<p>Each experiment's configuration as its database stores it (the runs used "
            "exactly these); rows where the experiments differ are highlighted.</p>",
            *_table(SETTINGS_TABLE, columns, rows, differs), "</section>"]


def _shown(value: object) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def write_page(included: Included, out_dir: Path, figures: Sequence[Path],
               tables: Sequence[Path], parts: Sequence[Section],
               commands: Sequence[Command]) -> Path:
    """Write ``out_dir/index.html`` (see the module docstring); its path."""
    title = f"Report of {included.root}"
    nav = [(_anchor(parts[0]), "Compared"), ("figures", "Figures"),
           *[(_anchor(p), _short(p.title)) for p in parts[1:]],
           ("reproduce", "Reproduce"), ("section-settings", "Settings")]
    files = " ".join(f'<a href="{html.escape(p.relative_to(out_dir).as_posix())}">'
                     f"{html.escape(p.name)}</a>" for p in tables)
    lines = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
             '<meta name="viewport" content="width=device-width, initial-scale=1">',
             f"<title>{html.escape(title)}</title>", f"<style>{_STYLE}</style>", "</head>",
             "<body>", f"<h1>{html.escape(title)}</h1>",
             f"<p>Made by revolve-env {html.escape(package_version())}. Tables as files: "
             f"{files}.</p>",
             "<nav>" + "".join(f'<a href="#{a}">{html.escape(t)}</a>' for a, t in nav)
             + "</nav>"]
    lines += _section(parts[0])
    lines += _figures(out_dir, figures)
    for part in parts[1:]:
        lines += _section(part)
    lines += _commands(commands)
    lines += _settings(included)
    lines += ["</body>", "</html>"]
    path = out_dir / PAGE_NAME
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
