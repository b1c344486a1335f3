"""The docs quote the curated float32 results by hand (docs/CLAIMS.md, the README's results paragraph,
runs/curated/study-f32/README.md and runs/curated/study-f32-walker-1m/README.md): every figure they
quote must equal the file it comes from (a report's results.json, `compare`'s compare.json,
`published`'s JSON) as the document rounds it (once, from the float). When a curated cell changes and
its files are redrawn, this fails until the docs are updated with it."""

from __future__ import annotations

import json
import os

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REPORT_1M = "runs/curated/study-f32-walker-1m/report/results.json"
REPORT_300K = "runs/curated/study-f32/report-300k/results.json"
MINUS = "\u2212"


def _signed(x: float, digits: int) -> str:
    """``+196`` / ``−165`` as CLAIMS.md writes signed figures (Unicode minus)."""
    s = f"{x:+.{digits}f}"
    return s.replace("-", MINUS)


def _comparison(c: dict, digits: int, ci: bool = True) -> str:
    """``−165 [−818, +551]``: a per-seed difference and its bootstrap CI (``ci=False``: ``−165``)."""
    text = _signed(c["diff"], digits)
    if ci:
        lo, hi = c["diff_ci95"]
        text += f" [{_signed(lo, digits)}, {_signed(hi, digits)}]"
    return text


def _p(c: dict) -> str:
    """Welch's two-sided p, two decimals."""
    return f"{c['welch']['p_two_sided']:.2f}"


def _interval(v: list[float]) -> str:
    return f"{v[0]:.3f} [{v[1]:.3f}, {v[2]:.3f}]"


def _interval2(v: list[float]) -> str:
    return f"{v[0]:.2f} [{v[1]:.2f}, {v[2]:.2f}]"


def _read(path: str) -> str:
    """A file of the repository (``path`` relative to its root, with ``/``)."""
    with open(os.path.join(REPO, *path.split("/")), encoding="utf-8") as f:
        return f.read()


def _text(path: str) -> str:
    """A document of the repository with its line breaks as spaces (quotes wrap anywhere)."""
    return " ".join(_read(path).split())


def _json(path: str):
    return json.loads(_read(path))


@pytest.fixture(scope="module")
def claims() -> str:
    return _text("docs/CLAIMS.md")


@pytest.fixture(scope="module")
def reports() -> tuple[dict, dict]:
    return _json(REPORT_1M), _json(REPORT_300K)


def _walker_1m_quotes(r1m: dict) -> list[str]:
    w = r1m["envs"]["Walker2d-v5"]
    t, c, power = w["table2"], w["comparisons"], w["verdict_power"]
    return [
        f"Swim {t['swim']['max_mean']:.0f} ± {t['swim']['max_std']:.0f}, "
        f"Swish {t['swish']['max_mean']:.0f} ± {t['swish']['max_std']:.0f}",
        f"**{_signed(w['improvement_pct']['max'], 1)} %**",
        f"per-seed max {_comparison(c['swim_vs_swish']['max'], 0)}, p {_p(c['swim_vs_swish']['max'])}",
        f"({power['seeds_for_paper_difference']} a side for 80 %)",
        f"{power['detectable_pct_of_swish']:.0f} % on Walker2d at 1M",
        f"Walker2d at 1M {_signed(c['swim_vs_swish']['auc']['diff'], 0)} (p {_p(c['swim_vs_swish']['auc'])})",
        f"Swim {_signed(c['swim_vs_relu']['max']['diff'], 0)} (p {_p(c['swim_vs_relu']['max'])}), "
        f"Swish {_signed(c['swish_vs_relu']['max']['diff'], 0)} (p {_p(c['swish_vs_relu']['max'])}) over ReLU",
    ]


def _table2_300k_quotes(r300: dict) -> list[str]:
    quotes = []
    for env, name, digits in (("Hopper-v5", "Hopper", 0), ("HalfCheetah-v5", "HalfCheetah", 0),
                              ("Swimmer-v5", "Swimmer", 1)):
        e = r300["envs"][env]
        m = e["comparisons"]["swim_vs_swish"]["max"]
        quotes.append(f"{name}-v5 at 300k: {_signed(e['improvement_pct']['max'], 1)} %")
        quotes.append(f"{_comparison(m, digits)}, p {_p(m)}")
    auc = {env: r300["envs"][env]["comparisons"]["swim_vs_swish"]["auc"]
           for env in ("Walker2d-v5", "Hopper-v5", "HalfCheetah-v5", "Swimmer-v5")}
    quotes += [
        f"at 300k Walker2d {_comparison(auc['Walker2d-v5'], 0, ci=False)} (p {_p(auc['Walker2d-v5'])})",
        f"Hopper {_comparison(auc['Hopper-v5'], 0, ci=False)} (p {_p(auc['Hopper-v5'])})",
        f"HalfCheetah {_comparison(auc['HalfCheetah-v5'], 0, ci=False)} (p {_p(auc['HalfCheetah-v5'])})",
        f"Swimmer {_comparison(auc['Swimmer-v5'], 1)} (p {_p(auc['Swimmer-v5'])})",
    ]
    powers = {env: r300["envs"][env]["verdict_power"]["detectable_pct_of_swish"] for env in r300["envs"]}
    low, high = min(powers, key=powers.get), max(powers, key=powers.get)
    quotes.append(f"{powers[low]:.0f} % ({low.split('-')[0]}) to {powers[high]:.0f} % ({high.split('-')[0]})")
    agg = r300["aggregate"]
    iqm = {a: agg["metrics"][a]["iqm"] for a in ("swim", "swish", "relu")}
    poi = agg["probability_of_improvement"]
    quotes += [
        f"IQM Swim {_interval(iqm['swim'])}, Swish {_interval(iqm['swish'])}",
        f"IQM ReLU {_interval(iqm['relu'])}",
        f"P(Swim > Swish) {_interval2(poi['swim_vs_swish'])}",
        f"P(Swim > ReLU) {_interval2(poi['swim_vs_relu'])}, P(Swish > ReLU) {_interval2(poi['swish_vs_relu'])}",
    ]
    return quotes


def test_claims_quote_the_walker2d_1m_report(claims, reports):
    missing = [q for q in _walker_1m_quotes(reports[0]) if q not in claims]
    assert not missing, f"docs/CLAIMS.md does not say what {REPORT_1M} says: {missing}"


def test_claims_quote_the_300k_report(claims, reports):
    missing = [q for q in _table2_300k_quotes(reports[1]) if q not in claims]
    assert not missing, f"docs/CLAIMS.md does not say what {REPORT_300K} says: {missing}"


def test_a_changed_report_is_caught(claims, reports):
    """The check can fail: the 1M report with Swim's max moved by one no longer matches."""
    changed = json.loads(json.dumps(reports[0]))
    changed["envs"]["Walker2d-v5"]["table2"]["swim"]["max_mean"] += 1.0
    assert any(q not in claims for q in _walker_1m_quotes(changed))


def _gymnasium_gap_pct(report: dict) -> float:
    """Largest |Gymnasium's mean − ours| / ours over the report's checked cells, in %."""
    return max(abs(c["gymnasium_minus_ours"]) / abs(c["ours_mean"]) * 100
               for cells in report["gymnasium_check"].values() for c in cells.values())


def test_readme_quotes_the_reports(reports):
    """The README's results paragraph: Walker2d at 1M, the 300k aggregates, the Gymnasium check."""
    r1m, r300 = reports
    readme = _text("README.md")
    w = r1m["envs"]["Walker2d-v5"]
    t, sw = w["table2"], w["comparisons"]["swim_vs_swish"]["max"]
    iqm = {a: r300["aggregate"]["metrics"][a]["iqm"][0] for a in ("swim", "swish", "relu")}
    poi = r300["aggregate"]["probability_of_improvement"]
    quotes = [
        f"Swim {t['swim']['max_mean']:.0f} ± {t['swim']['max_std']:.0f}, Swish {t['swish']['max_mean']:.0f} ± "
        f"{t['swish']['max_std']:.0f}, ReLU {t['relu']['max_mean']:.0f} ± {t['relu']['max_std']:.0f}",
        f"Swim vs Swish {_signed(w['improvement_pct']['max'], 1)} %, Welch p {_p(sw)}",
        f"IQM of normalized scores {iqm['swim']:.2f} and {iqm['swish']:.2f} against {iqm['relu']:.2f}",
        f"over ReLU {poi['swim_vs_relu'][0]:.2f} and {poi['swish_vs_relu'][0]:.2f}",
    ]
    missing = [q for q in quotes if q not in readme]
    assert not missing, f"README.md's results paragraph does not say what the reports say: {missing}"
    for report, words in ((r300, "every Table II cell's mean at 300k lies within"),
                          (r1m, "every 1M cell's within")):
        quoted = float(readme.split(words, 1)[1].split("%", 1)[0])
        assert _gymnasium_gap_pct(report) <= quoted < _gymnasium_gap_pct(report) + 0.2, (words, quoted)


def test_claims_gymnasium_bound_covers_both_reports(claims, reports):
    """CLAIMS.md's "every checked Table II cell's mean lies within X %" is the larger of the two reports' gaps."""
    quoted = float(claims.split("every checked Table II cell's mean lies within", 1)[1].split("%", 1)[0])
    gap = max(_gymnasium_gap_pct(r) for r in reports)
    assert gap <= quoted < gap + 0.1, (quoted, gap)


ACTIVATIONS = (("Swim", "swim"), ("Swish", "swish"), ("ReLU", "relu"))  # (as the docs write it, results.json key)


def _mean_std(cell: dict, score: str, digits: int) -> str:
    return f"{cell[score + '_mean']:.{digits}f} ± {cell[score + '_std']:.{digits}f}"


def _scores_cells(cell: dict, digits: int, bold_max: bool = False) -> str:
    """``4150 ± 546 (955k) | 4143 ± 664 | 2504 ± 497 |``: a Table II row's max (at step), final and AUC."""
    mx = _mean_std(cell, "max", digits)
    return (f"{f'**{mx}**' if bold_max else mx} ({cell['max_step'] // 1000}k) | {_mean_std(cell, 'final', digits)} | "
            f"{_mean_std(cell, 'auc', digits)} |")


def test_study_readme_tables_are_the_reports(reports):
    """runs/curated/study-f32/README.md's Table II at 300k, its aggregates and its 1M table."""
    r1m, r300 = reports
    text = _text("runs/curated/study-f32/README.md")
    rows = []
    for env, e in r300["envs"].items():
        digits = 1 if env.startswith("Swimmer") else 0
        t, m = e["table2"], e["comparisons"]["swim_vs_swish"]["max"]
        verdict = "too weak" if e["verdict"].startswith("Evidence too weak") else "sufficient"
        rows.append(f"| {env} | {_mean_std(t['swim'], 'max', digits)} | {_mean_std(t['swish'], 'max', digits)} | "
                    f"{_mean_std(t['relu'], 'max', digits)} | {_signed(e['improvement_pct']['max'], 1)} %;")
        rows.append(f"{_comparison(m, digits)}, p {_p(m)} | {verdict} |")
    metrics = r300["aggregate"]["metrics"]
    for name, a in ACTIVATIONS:
        rows.append(f"| {name} | {_interval(metrics[a]['iqm'])} | {_interval(metrics[a]['mean'])} | "
                    f"{_interval(metrics[a]['optimality_gap'])} |")
        rows.append(f"| {name} | {_scores_cells(r1m['envs']['Walker2d-v5']['table2'][a], 0)}")
    missing = [r for r in rows if r not in text]
    assert not missing, f"runs/curated/study-f32/README.md does not say what the reports say: {missing}"


def test_study_readme_per_env_table_is_the_report(reports):
    """runs/curated/study-f32/README.md's "Per env at 300k" rows: max (at step), final, AUC."""
    text = _text("runs/curated/study-f32/README.md")
    rows = []
    for env, e in reports[1]["envs"].items():
        digits = 1 if env.startswith("Swimmer") else 0
        for i, (name, a) in enumerate(ACTIVATIONS):
            rows.append(f"|{' ' + env if i == 0 else ''} | {name} | {_scores_cells(e['table2'][a], digits)}")
    missing = [r for r in rows if r not in text]
    assert not missing, f"runs/curated/study-f32/README.md's per-env table is not the report's: {missing}"


def test_walker_1m_readme_is_its_reports(reports):
    """runs/curated/study-f32-walker-1m/README.md: its table, verdict, power line and the 300k read."""
    text = _text("runs/curated/study-f32-walker-1m/README.md")
    at300 = _json("runs/curated/study-f32-walker-1m/report-at-300k/results.json")["envs"]["Walker2d-v5"]
    w = reports[0]["envs"]["Walker2d-v5"]
    c, power = w["comparisons"], w["verdict_power"]
    quotes = []
    for name, a in ACTIVATIONS:  # (the README sets the highest max, Swish's, in bold)
        t = w["table2"][a]
        quotes.append(f"| {name} | {t['seeds']} | {_scores_cells(t, 0, bold_max=a == 'swish')}")
    s = c["swim_vs_swish"]
    quotes += [
        f"per-seed max {_comparison(s['max'], 0)}, Welch p {_p(s['max'])}",
        f"Final {_comparison(s['final'], 0, ci=False)} (p {_p(s['final'])}), "
        f"AUC {_comparison(s['auc'], 0)} (p {_p(s['auc'])})",
        f"finds a true difference of {power['detectable_difference']:.0f} "
        f"({power['detectable_pct_of_swish']:.0f} % of Swish's mean)",
        f"{power['seeds_for_paper_difference']} a side are needed for 80 %",
        f"Swim {_comparison(c['swim_vs_relu']['max'], 0)} on the per-seed max (p {_p(c['swim_vs_relu']['max'])})",
        f"Swish {_comparison(c['swish_vs_relu']['max'], 0)} (p {_p(c['swish_vs_relu']['max'])})",
        f"on AUC {_comparison(c['swish_vs_relu']['auc'], 0)} (p {c['swish_vs_relu']['auc']['welch']['p_two_sided']:.3f})",
        f"Swim {_mean_std(at300['table2']['swim'], 'max', 0)}, Swish {_mean_std(at300['table2']['swish'], 'max', 0)}, "
        f"ReLU {_mean_std(at300['table2']['relu'], 'max', 0)} (max of the mean)",
        f"per-seed max {_comparison(at300['comparisons']['swim_vs_swish']['max'], 0)}, "
        f"p {_p(at300['comparisons']['swim_vs_swish']['max'])}",
    ]
    missing = [q for q in quotes if q not in text]
    assert not missing, f"runs/curated/study-f32-walker-1m/README.md does not say what its reports say: {missing}"


def _published(path: str) -> dict:
    """`published --json`'s rows of ``runs/curated/<path>`` by (activation, step)."""
    return {(e["activation"], e["step"]): e for e in _json("runs/curated/" + path)}


def test_claims_quote_published_td3_comparisons(claims):
    """CLAIMS.md's "Our TD3 itself is where published TD3 is" paragraph, against `published`'s JSON."""
    at1m = _published("study-f32-walker-1m/published-1m.json")
    ten = _published("study-f32-seeds5-9/published-relu-10seeds.json")[("relu", 300000)]
    r = at1m[("relu", 1000000)]
    quotes = [
        f"ReLU on Walker2d-v5 at 1M {r['ours_mean']:.0f} ± {r['ours_sd']:.0f} against Tianshou's TD3 "
        f"{r['published']['mean']:.0f} ± {r['published']['sd']:.0f} (p {r['welch_p']:.2f})",
        f"at 300k Walker2d's ReLU starts later ({_signed(at1m[('relu', 300000)]['diff'], 0)}, "
        f"p {at1m[('relu', 300000)]['welch_p']:.3f})",
        f"ten seeds at 300k ({ten['ours_mean']:.0f} ± {ten['ours_sd']:.0f}) it is inside the published "
        f"spread too (p {ten['welch_p']:.2f}",
    ]
    v4 = _published("study-f32-walker-v4-seeds5-9/published-v4-10seeds.json")[("relu", 300000)]
    quotes.append(f"Walker2d-v4, the version of Tianshou's model and rewards ({v4['ours_mean']:.0f} ± "
                  f"{v4['ours_sd']:.0f}, ten seeds, p {v4['welch_p']:.2f};")
    assert ten["ours_n"] == 10 and v4["ours_n"] == 10
    missing = [q for q in quotes if q not in claims]
    assert not missing, f"docs/CLAIMS.md does not say what `published` says: {missing}"


def _precision_rows() -> list[tuple[str, dict]]:
    """(README row prefix, compare.json cell) for every precision pair of runs/curated/study-f32/README.md."""
    rows = []
    for path, renamed in (("study-f32/precision/compare.json", "walker_swim (null pair"),
                          ("study-table2-walker-swim-bf16/precision/compare.json", "walker_swim against its bfloat16 run")):
        cells = _json("runs/curated/" + path)["cells"]
        rows += [(f"| {renamed if name == 'walker_swim' else name + ' |'}", cell) for name, cell in cells.items()]
    return rows


def test_precision_table_is_the_compare_output():
    """Every row of the README's precision table: each score's difference (and CI) and the verdict."""
    lines = _read("runs/curated/study-f32/README.md").splitlines()
    rows = _precision_rows()
    assert len(rows) == 13  # 12 bfloat16 pairs and the float32 null pair
    wrong = []
    for prefix, cell in rows:
        line = next((ln for ln in lines if ln.startswith(prefix)), None)
        assert line is not None, f"no precision row {prefix!r}"
        digits = 1 if cell["env"].startswith("Swimmer") else 0
        for score in ("max", "final", "auc"):
            s = {"diff": cell["scores"][score]["diff"], "diff_ci95": cell["scores"][score]["diff_ci"]}
            quote = _comparison(s, digits, ci=score != "final")  # the table gives final without its CI
            if quote not in line:
                wrong.append(f"{prefix} {score}: {quote}")
        verdict = line.rstrip(" |").rsplit("|", 1)[1]
        if ("no" in verdict and "yes" not in verdict and "only" not in verdict) != (not cell["changed"]):
            wrong.append(f"{prefix} changed: {cell['changed']}, the row says {verdict.strip()!r}")
    assert not wrong, f"runs/curated/study-f32/README.md's precision table is not compare's output: {wrong}"
