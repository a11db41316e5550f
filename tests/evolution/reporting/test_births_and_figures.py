"""Births counted without failed births, lost robots, labels and colours, step drawing, shared
scales, legends outside the data, brain-aware diversity.

Runs use the physics stand-ins of ``experiment_fakes``: offline evaluations where one robot in
five blows up, and the fake shared world.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from experiment_fakes import fake_evaluate_with_losses, fake_world, small

from evolution.diversity import brain_aware_diversity, diversity
from evolution.evaluation import LocalEvaluator
from evolution.experiments import preset, run
from evolution.experiments.store.database import DB_NAME, Store
from evolution.reporting import find_experiments, report
from evolution.reporting.data import LABELS, ExperimentData, births_axis, common_births
from evolution.reporting.figures import (
    FIGURES,
    curve_tests,
    final_fitness,
    fitness_over_births,
    lost_robots,
)
from evolution.reporting.style import PAPER_COLORS, TEXT_SIZE, colors, contrast_ratio, text_color
from revolve_env.body.serialize import from_json

LOSSY = LocalEvaluator(workers=1, function=fake_evaluate_with_losses)


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Scenario 1 with blow-ups and scenario 3 in the fake world, two runs each."""
    root = tmp_path_factory.mktemp("births")
    run(small(preset("scenario1", births=30, runs=2, diversity_interval=10)),
        root / "scenario1", evaluator=LOSSY)
    run(small(preset("scenario3", births=20, runs=2, diversity_interval=10)),
        root / "scenario3", evaluator=LOSSY, world_factory=fake_world)
    return root


@pytest.fixture(scope="module")
def offline_pair(results: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The results above and baseline A (offline, two runs): a pair of one mode to compare."""
    root = tmp_path_factory.mktemp("pair")
    for name in ("scenario1", "scenario3"):
        shutil.copytree(results / name, root / name)
    run(small(preset("baseline_a", births=30, runs=2, diversity_interval=10)),
        root / "baseline_a", evaluator=LOSSY)
    return root


def _drawn(figure: object) -> list[object]:
    """The visible, non-empty texts of a figure once drawn (tick labels are made then)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    FigureCanvasAgg(figure)  # type: ignore[arg-type]
    figure.canvas.draw()  # type: ignore[attr-defined]
    return [t for t in figure.findobj(Text)  # type: ignore[attr-defined]
            if t.get_visible() and t.get_text().strip()]


def test_births_axis_takes_the_failed_births_off() -> None:
    np.testing.assert_array_equal(births_axis(np.array([15, 17, 32]), np.array([3, 16, 20])),
                                  [14, 15, 29])


def test_failed_births_are_not_births_and_are_counted_apart(results: Path) -> None:
    (offline, _) = find_experiments(results, brain_aware=False)
    assert offline.name == "scenario1"
    with Store.open(results / "scenario1" / DB_NAME) as store:
        for r in offline.runs:
            lost = sorted(f.robot_id for f in store.failures(r.run_id, "evaluation"))
            engine = [b for b, _, _ in store.population_snapshots(r.run_id)]
            assert np.array_equal(r.failed_births, lost) and r.lost_robots == len(lost)
            assert store.runs()[r.run_id].births == 30 and r.births == 30 - len(lost)
            # Generation 0 ends when 15 robots were evaluated, however many blew up.
            assert r.fitness.births[0] == 15 and engine[0] == 15 + sum(i < engine[0] for i in lost)
            assert r.fitness.births.tolist() == [b - sum(i < b for i in lost) for b in engine]
    assert sum(r.failed_births.size for r in offline.runs) > 0  # the fake did blow robots up


def _legend(figure: object) -> list[str]:
    """The texts of the legend below a figure's panels."""
    (legend,) = figure.subfigs[0].legends  # type: ignore[attr-defined]
    return [t.get_text() for t in legend.get_texts()]


def test_lost_robots_figure_counts_every_lost_robot(results: Path) -> None:
    experiments = find_experiments(results)
    figure = lost_robots(experiments)
    ax = figure.axes[0]
    offline = experiments[0]
    heights = [line.get_ydata()[-1] for line in ax.lines[:len(offline.runs)]]
    assert heights == [r.lost_robots for r in offline.runs]
    assert all(line.get_drawstyle() == "steps-post" for line in ax.lines)
    lost = sum(r.lost_robots for r in offline.runs)
    failed = sum(r.failed_births.size for r in offline.runs)
    assert lost > 0 and _legend(figure)[0].startswith(
        f"Scenario 1 (15+15): {lost} lost ({failed} failed births")


def test_offline_and_online_share_a_y_scale_with_every_run_drawn(results: Path) -> None:
    experiments = find_experiments(results)
    figure = fitness_over_births(experiments)
    (off_mean, on_mean, off_best, on_best) = figure.axes[:4]
    assert "Offline" in off_mean.get_title() and "Online" in on_mean.get_title()
    assert "best" in off_best.get_title() and "best" in on_best.get_title()
    # One y-scale per row: offline and online fitness can be compared by eye.
    assert off_mean.get_ylim() == on_mean.get_ylim() and off_best.get_ylim() == on_best.get_ylim()
    # Budgets differ here (30 and 20 births), but robots were lost before their first fitness:
    # the births axis is not the engines' count, so the caption says where runs compare.
    assert not [line for line in off_mean.lines if line.get_linestyle() == ":"]
    curves = [line for line in off_mean.lines if len(line.get_xdata()) > 1]  # not the end dot
    assert curves and {line.get_drawstyle() for line in curves} == {"steps-post"}
    assert {line.get_drawstyle() for line in on_mean.lines} == {"default"}
    offline = experiments[0]
    assert len(curves) == len(offline.runs) + 1  # every run, then the median
    assert off_mean.get_legend() is None and on_mean.get_legend() is None  # none over the data
    lost = sum(r.lost_robots for r in offline.runs)
    assert _legend(figure) == [f"Scenario 1 (15+15): 2 runs, {lost} lost",
                               "Scenario 3 (online): 2 runs, 0 lost"]
    caption = " ".join(" ".join(t.get_text() for sub in figure.subfigs for t in sub.texts).split())
    assert "sliding-window fitness" in caption and "isolated evaluation" in caption
    assert "failed birth" in caption and "one y-scale" in caption
    assert "every run reached 20 births" in caption


def test_every_robot_of_the_compared_populations_is_a_point(results: Path) -> None:
    """Scenario 1 ran 30 births, scenario 3 20: both are drawn at 20, like with like."""
    experiments = find_experiments(results)
    assert common_births(experiments) == 20
    figure = final_fitness(experiments)
    offline_ax, online_ax = figure.axes[:2]
    assert offline_ax.get_ylim() == online_ax.get_ylim()
    assert "at 20 births" in figure.subfigs[0].get_suptitle()
    for ax, e in ((offline_ax, experiments[0]), (online_ax, experiments[1])):
        robots, means = ax.collections[:2]
        populations = [p.fitness for p in e.populations_at(20)]
        np.testing.assert_allclose(np.sort(robots.get_offsets()[:, 1]),
                                   np.sort(np.concatenate(populations)))
        np.testing.assert_allclose(np.sort(means.get_offsets()[:, 1]),
                                   np.sort([f.mean() for f in populations]))
    # Offline at 20 births: generation 0, before the run's final generation.
    assert all(p.births < r.engine_births == 30 for p, r in
               zip(experiments[0].populations_at(20), experiments[0].runs, strict=True))
    # The best robot is drawn however far it lies from the box.
    best = max(p.fitness.max() for p in experiments[0].populations_at(20))
    assert best in offline_ax.collections[0].get_offsets()[:, 1]


def _fake(name: str, label: str | None = None) -> ExperimentData:
    return ExperimentData(label or name, Path(name), {"name": name}, ())


def test_labels_order_and_colours() -> None:
    experiments = [_fake(n) for n in ("scenario1", "scenario2", "scenario3", "baseline_a",
                                      "baseline_b", "custom", "quick")]
    assert [e.title for e in experiments[:5]] == list(LABELS.values())
    assert experiments[5].title == "custom"
    assert _fake("scenario1", "a/scenario1").title == "Scenario 1 (15+15) [a/scenario1]"
    palette = colors(experiments)
    assert [palette[e.label] for e in experiments[:5]] == list(PAPER_COLORS.values())
    assert len(set(palette.values())) == len(experiments)
    # The same experiment keeps its colour whatever else is reported.
    assert colors([_fake("quick"), _fake("scenario3")])["scenario3"] == PAPER_COLORS["scenario3"]


def test_quick_is_listed_after_the_paper_experiments(tmp_path: Path, results: Path) -> None:
    import shutil

    for name in ("scenario3", "scenario1"):
        shutil.copytree(results / name, tmp_path / name)
    shutil.copytree(results / "scenario1", tmp_path / "aaa")  # another scenario1: by path
    labels = [e.label for e in find_experiments(tmp_path)]
    assert labels == ["aaa", "scenario1", "scenario3"]


def test_brain_aware_report(results: Path, tmp_path: Path) -> None:
    result = report(results, tmp_path / "out", formats=("png",), brain_aware=True)
    (offline, _) = result.experiments
    with Store.open(results / "scenario1" / DB_NAME) as store:
        r = offline.runs[0]
        final = [rid for rid, _ in store.final_population(r.run_id)]
        robots = [from_json(x.genome, check=False) for x in store.robots(r.run_id, final)]
    assert r.brain_diversity.size == r.diversity.size > 0
    assert np.all(r.brain_diversity >= r.diversity)
    assert r.final_brain_diversity == pytest.approx(brain_aware_diversity(robots))
    assert r.final_brain_diversity >= diversity(robots)
    assert (tmp_path / "out" / "diversity_over_births.png").stat().st_size > 5000


def test_heatmap_text_reads_on_every_cell(offline_pair: Path) -> None:
    """Cell text is black or white, whichever contrasts more: at least WCAG's 4.5 on every
    colour of the scale (black text on the darkest cells was 1.5 to 2)."""
    from matplotlib import colormaps
    from matplotlib.colors import to_rgb

    figure = curve_tests(find_experiments(offline_pair))
    ax = figure.axes[0]
    (image,) = ax.images
    cells = image.get_array()
    assert ax.texts
    for text in ax.texts:
        x, y = text.get_position()
        background = image.cmap(image.norm(cells[int(y), int(x)]))
        assert contrast_ratio(background, to_rgb(text.get_color())) >= 4.5
    for value in np.linspace(0.0, 1.0, 101):
        background = colormaps["RdBu_r"](value)
        assert contrast_ratio(background, to_rgb(text_color(background))) >= 4.5
    assert text_color((0.02, 0.19, 0.38)) == "white" and text_color((0.97, 0.97, 0.97)) == "black"


def test_every_figure_has_one_text_size(offline_pair: Path) -> None:
    experiments = find_experiments(offline_pair)
    for stem, draw in FIGURES.items():
        texts = _drawn(draw(experiments))
        assert len(texts) > 5, stem
        sizes = {t.get_fontsize() for t in texts}  # type: ignore[attr-defined]
        assert sizes == {TEXT_SIZE}, (stem, sizes)


def test_online_panels_have_their_own_y_tick_labels(results: Path) -> None:
    experiments = find_experiments(results)
    for figure, panels in ((fitness_over_births(experiments), 4), (final_fitness(experiments), 2)):
        _drawn(figure)
        for ax in figure.axes[:panels]:
            numbers = [t.get_text() for t in ax.get_yticklabels()
                       if t.get_visible() and t.get_text()]
            assert len(numbers) >= 2, ax.get_title()


def test_the_curve_heatmap_pairs_like_with_like(results: Path, offline_pair: Path) -> None:
    figure = curve_tests(find_experiments(offline_pair))
    rows = [t.get_text() for t in figure.axes[0].get_yticklabels()]
    assert len(rows) == 1 and rows[0].startswith("Scenario 1") and "Baseline A" in rows[0]
    assert not any("Scenario 3" in row for row in rows)  # online, never with offline
    # One offline and one online experiment: no pair, and the figure says why.
    alone = curve_tests(find_experiments(results))
    assert not alone.axes[0].get_yticklabels() or not any(
        t.get_text() for t in alone.axes[0].get_yticklabels())
    assert any("offline with offline" in t.get_text() for t in alone.axes[0].texts)
