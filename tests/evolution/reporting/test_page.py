"""``report/index.html``: parsed with the standard library, and opened in a headless browser
when one is installed (Debian: ``apt-get install chromium``; the test skips without one).

The experiments run on the fast physics stand-ins of ``experiment_fakes``.
"""

from __future__ import annotations

import csv
import json
import shlex
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest
from experiment_fakes import fake_evaluate, fake_evaluate_with_losses, fake_world, small

from evolution.cli.commands import build_parser
from evolution.cli.options import parse_set
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ExperimentConfig, load_config, preset, run
from evolution.experiments.app.api import flat_keys
from evolution.experiments.app.reevaluate import reevaluate
from evolution.experiments.store.database import DB_NAME, Store
from evolution.reporting import Report, report
from evolution.reporting.optimism import MARKDOWN_COLUMNS
from evolution.reporting.page import SETTINGS_TABLE
from evolution.reporting.reproduce import EXECUTION_KEYS
from evolution.reporting.tables import (
    INCLUDED_COLUMNS,
    MANN_WHITNEY_COLUMNS,
    POOLED_SHOWN_COLUMNS,
    SUMMARY_COLUMNS,
)

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)


class Page(HTMLParser):
    """What a test needs from the page: images, links, tables (header and rows), code, text."""

    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.links: list[str] = []
        self.scripts = 0
        self.tables: dict[str, tuple[list[str], list[list[str]]]] = {}
        self.code: list[str] = []
        self.text: list[str] = []
        self._table: str | None = None
        self._cell: list[str] | None = None
        self._row: list[str] | None = None
        self._in_code = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "img":
            self.images.append(str(a["src"]))
        elif tag == "a" and "href" in a:
            self.links.append(str(a["href"]))
        elif tag in ("script", "iframe", "object", "embed"):
            self.scripts += 1
        elif tag == "table":
            self._table = str(a["id"])
            self.tables[self._table] = ([], [])
        elif tag == "tr" and self._table is not None:
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = []
        elif tag == "code":
            self._in_code = True
            self.code.append("")

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._row.append("".join(self._cell))
            self._cell = None
        elif tag == "tr" and self._row is not None and self._table is not None:
            header, rows = self.tables[self._table]
            if not header:
                header.extend(self._row)
            else:
                rows.append(self._row)
            self._row = None
        elif tag == "table":
            self._table = None
        elif tag == "code":
            self._in_code = False

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)
        if self._in_code:
            self.code[-1] += data
        self.text.append(data)


def _parse(path: Path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Scenario 1 with losses and scenario 3, two runs each, reevaluated twice."""
    root = tmp_path_factory.mktemp("page") / "results"
    run(small(preset("scenario1", births=30, runs=2, diversity_interval=10)),
        root / "scenario1", evaluator=LocalEvaluator(workers=1,
                                                     function=fake_evaluate_with_losses))
    run(small(preset("scenario3", births=20, runs=2, diversity_interval=10)),
        root / "scenario3", evaluator=SERIAL, world_factory=fake_world)
    reevaluate(root, k=2, evaluator=SERIAL)
    return root


@pytest.fixture(scope="module")
def written(results: Path) -> Report:
    return report(results)


def test_every_image_and_link_is_a_file_beside_the_page(written: Report) -> None:
    page = _parse(written.page)
    assert written.page == written.out_dir / "index.html"
    stems = {p.stem for p in written.figures}
    assert {"fitness_over_births", "final_fitness", "lost_robots", "optimism"} <= stems
    assert sorted(Path(src).stem for src in page.images) == sorted(stems)  # each figure once
    for target in page.images + [link for link in page.links if not link.startswith("#")]:
        assert "/" not in target and ":" not in target, target  # relative, beside the page
        assert (written.out_dir / target).is_file(), target
    anchors = {link[1:] for link in page.links if link.startswith("#")}
    html_text = written.page.read_text()
    assert all(f'id="{a}"' in html_text for a in anchors)
    assert page.scripts == 0  # opening the page runs no code
    assert "http://" not in html_text and "https://" not in html_text


def test_every_table_has_its_columns_and_the_csv_rows(written: Report, results: Path) -> None:
    page = _parse(written.page)
    out = written.out_dir
    expected = {"included": INCLUDED_COLUMNS, "summary": SUMMARY_COLUMNS,
                "tests_per_run": MANN_WHITNEY_COLUMNS, "tests_pooled": POOLED_SHOWN_COLUMNS,
                "optimism": MARKDOWN_COLUMNS}
    for name, columns in expected.items():
        assert tuple(page.tables[name][0]) == columns, name
    # Scenario 1 is offline, scenario 3 online: no pair of one mode, so no whole-curve table.
    assert "curve_summary" not in page.tables and "(no pair to compare)" in page.text
    for name, csv_name in (("summary", "summary.csv"), ("tests_per_run", "tests_per_run.csv"),
                           ("tests_pooled", "tests_pooled_descriptive.csv"),
                           ("optimism", "optimism.csv")):
        stored = _rows(out / csv_name)
        shown = page.tables[name][1]
        assert len(shown) == len(stored) > 0, name
        assert [r[0] for r in shown] == [r[next(iter(r))] for r in stored]
    # Lost robots counted apart: the failures each database recorded.
    included = {row[0]: dict(zip(INCLUDED_COLUMNS, row, strict=True))
                for row in page.tables["included"][1]}
    with Store.open(results / "scenario1" / DB_NAME) as store:
        lost = len({f.robot_id for r in store.runs() for f in store.failures(r.run_id)
                    if f.kind == "evaluation"})
    assert lost > 0 and included["scenario1"]["lost_robots"] == str(lost)
    assert included["scenario3"]["lost_robots"] == "0"
    assert included["scenario1"]["births_budget"] == "30"


def _css(page: str) -> dict[str, str]:
    """The page's style sheet as selector -> declarations (whitespace folded)."""
    sheet = page[page.index("<style>") + 7:page.index("</style>")]
    rules = {}
    for block in sheet.split("}"):
        if "{" in block:
            selectors, body = block.split("{", 1)
            for selector in selectors.split(","):
                rules[" ".join(selector.split())] = " ".join(body.split())
    return rules


def test_wide_tables_wrap_and_scroll_inside_the_page(written: Report) -> None:
    """No table is cut at the page's 1,200 px: headers wrap after each underscore, text cells
    wrap, and what is still wider scrolls sideways in its own box."""
    text = written.page.read_text(encoding="utf-8")
    css = _css(text)
    assert "overflow-x: auto" in css[".scroll"] and "max-width: 100%" in css[".scroll"]
    assert "nowrap" not in css["th"] and "white-space: normal" in css["th"]
    assert "overflow-wrap: anywhere" in css["td.text"]
    assert not any("nowrap" in body for selector, body in css.items()
                   if selector in ("th", "td", "td.text", "table"))
    page = _parse(written.page)
    for name in page.tables:  # every table is the only thing in a scrolling box
        assert (f'<div class="scroll" role="region" tabindex="0" aria-label="{name}">\n'
                f'<table id="{name}">') in text, name
    assert "final_<wbr>fitness_<wbr>mean" in text  # a long header breaks at its underscores
    assert page.tables["summary"][0][0] == "experiment"  # and still reads as its name


def test_figures_are_shown_at_their_size_so_their_text_reads_alike(written: Report) -> None:
    from PIL import Image

    text = written.page.read_text(encoding="utf-8")
    shown = 0
    for png in (p for p in written.figures if p.suffix == ".png"):
        with Image.open(png) as image:
            width, height = image.size
        tag = next(line for line in text.splitlines() if f'src="{png.name}"' in line)
        assert f'width="{round(width * 96 / 150)}" height="{round(height * 96 / 150)}"' in tag
        shown += 1
    assert shown >= 6


def test_the_pooled_table_shows_no_p_values(written: Report) -> None:
    page = _parse(written.page)
    header = page.tables["tests_pooled"][0]
    assert not {"p_value", "p_min", "p_holm", "u_statistic"} & set(header)
    assert {"p_value", "p_holm"} <= set(page.tables["tests_per_run"][0])
    text = written.page.read_text(encoding="utf-8")
    assert text.index('id="tests_per_run"') < text.index('id="tests_pooled"')
    assert "its p-values are left out of this page" in " ".join(" ".join(page.text).split())


def test_the_settings_are_every_stored_config_key(written: Report, results: Path) -> None:
    header, rows = _parse(written.page).tables[SETTINGS_TABLE]
    assert header == ["setting", "scenario1", "scenario3"]
    by_key = {row[0]: row[1:] for row in rows}
    with Store.open(results / "scenario1" / DB_NAME) as store:
        config = flat_keys(store.config)
    assert set(config) <= set(by_key)
    assert by_key["mode"] == ["offline", "online"]
    assert by_key["births"] == ["30", "20"]
    assert by_key["evaluation.heading"][0] == str(config["evaluation.heading"])


def _command_config(line: str) -> ExperimentConfig:
    """The config ``revolve run`` would make from ``line``, as its handler builds it."""
    args = build_parser().parse_args(shlex.split(line)[1:])
    overrides = parse_set(args.set or [])
    for key in ("runs", "births", "seed", "workers", "name"):
        if getattr(args, key) is not None:
            overrides[key] = getattr(args, key)
    return load_config(args.config, overrides)


def test_the_commands_reproduce_the_stored_settings(written: Report, results: Path) -> None:
    commands = [c for c in _parse(written.page).code if c.startswith("revolve ")]
    runs = [c for c in commands if c.startswith("revolve run ")]
    assert len(runs) == 2
    for line in runs:
        made = _command_config(line)
        with Store.open(results / made.name / DB_NAME) as store:
            stored = flat_keys(store.config)
        mine = flat_keys(made.to_dict())
        assert {k: v for k, v in mine.items() if k not in EXECUTION_KEYS} == {
            k: v for k, v in stored.items() if k not in EXECUTION_KEYS}, line
        assert shlex.split(line)[shlex.split(line).index("--out") + 1] == str(results)
    reevaluations = [c for c in commands if c.startswith("revolve reevaluate ")]
    assert reevaluations and all("--k 2" in c for c in reevaluations)
    assert commands[-1] == shlex.join(["revolve", "report", str(results)])


def test_a_study_is_reproduced_by_its_study_command(tmp_path: Path) -> None:
    from evolution.experiments.app.study import study

    tiny = {"population_size": 4, "offspring_size": 4, "insertion": 0.5,
            "evaluation_time": 1.0, "fertile_age": 1.5, "diversity_interval": 4,
            "evolution": {"initial_parts_mean": 5.0, "initial_parts_sd": 2.0, "max_parts": 12}}
    out = tmp_path / "study"
    study(out, runs=2, births=12, experiments=("scenario1", "baseline_b"), overrides=tiny,
          seed=4, evaluator=SERIAL)
    page = _parse(report(out, formats=("png",)).page)
    (line,) = [c for c in page.code if c.startswith("revolve study ")]
    args = build_parser().parse_args(shlex.split(line)[1:])
    assert (args.out, args.runs, args.births, args.seed) == (str(out), 2, 12, 4)
    assert args.only == ["scenario1", "baseline_b"]
    assert parse_set(args.set) == tiny
    assert json.loads((out / "study.json").read_text())["overrides"] == tiny


def _browser() -> str | None:
    return next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                 if shutil.which(n)), None)


_CHECK = """<!DOCTYPE html><html><body>
<iframe id="page" src="index.html" width="1200" height="800"></iframe><pre id="out">pending</pre>
<script>
document.getElementById("page").addEventListener("load", function () {
  var doc = this.contentDocument;
  var images = Array.from(doc.images).map(function (i) {
    return [i.getAttribute("src"), i.complete && i.naturalWidth > 0]; });
  var tables = Array.from(doc.querySelectorAll("table")).map(function (t) {
    return [t.id, t.rows.length]; });
  document.getElementById("out").textContent =
    "RESULT" + JSON.stringify({title: doc.title, images: images, tables: tables}) + "END";
});
</script></body></html>
"""
"""A test-only page beside a copy of the report: it loads ``index.html`` and says which images
the browser decoded and which tables it laid out."""


def _open_in_browser(browser: str, folder: Path, profile: Path) -> dict[str, object]:
    (folder / "check.html").write_text(_CHECK, encoding="utf-8")
    done = subprocess.run(
        [browser, "--headless", "--no-sandbox", "--disable-gpu",
         "--disable-background-networking", "--no-first-run", "--disable-component-update",
         "--disable-sync", f"--user-data-dir={profile}", "--allow-file-access-from-files",
         "--virtual-time-budget=15000", "--dump-dom", (folder / "check.html").as_uri()],
        capture_output=True, text=True, timeout=120, check=False)
    dom = done.stdout
    assert "RESULT" in dom, done.stderr[-2000:]
    result: dict[str, object] = json.loads(dom[dom.index("RESULT") + 6:dom.index("END")])
    return result


@pytest.mark.skipif(_browser() is None, reason="no headless browser (apt-get install chromium)")
def test_the_page_opens_from_the_file_system_in_a_browser(written: Report,
                                                          tmp_path: Path) -> None:
    browser = _browser()
    assert browser is not None
    folder = tmp_path / "moved"  # a report folder moved elsewhere still opens whole
    shutil.copytree(written.out_dir, folder)
    shown = _open_in_browser(browser, folder, tmp_path / "profile")
    images = dict(shown["images"])  # type: ignore[call-overload]
    assert set(images) == {p.name for p in written.figures if p.suffix == ".png"}
    assert all(images.values()), images
    tables = dict(shown["tables"])  # type: ignore[call-overload]
    assert tables["tests_per_run"] == len(_rows(written.tables[1])) + 1
    assert shown["title"] == f"Report of {written.out_dir.parent}"
    # The check can fail: a missing figure is seen as broken.
    (folder / "lost_robots.png").unlink()
    shown = _open_in_browser(browser, folder, tmp_path / "profile2")
    images = dict(shown["images"])  # type: ignore[call-overload]
    assert images["lost_robots.png"] is False and images["final_fitness.png"] is True
