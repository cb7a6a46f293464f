"""The evaluation's counts (benchmarks/diagnose.py): rows written by hand, whose counts are known by construction,
counted as the validation tables count them; Wilson intervals against their closed form."""

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import diagnose as bench  # noqa: E402
from diagnose_truth2 import count_rows, gap_left, wilson  # noqa: E402

WITHIN = "missing effect: gear_play (gear backlash)"
LEFT = "a gap of 3.1 noise levels remains that no effect in the library explains (largest in step 1: 9.6 noise levels)"
ROUNDS_LEFT = ("found in 3 rounds: missing effect: gear_play (play = 0.0368); then missing effect: stiction; a gap of "
               "6.2 noise levels remains after 3 rounds (the job's decision.rounds)")
ROUNDS_WITHIN = ("found in 2 rounds: missing effect: gear_play; then law of another form: dahl_guide; what remains is "
                 "within the noise (1.4 noise levels RMS)")
DIFFUSE = "no effect named: a diffuse gap of 1.2 noise levels RMS remains (mean square 1.33 noise levels squared)"
FITS = "no missing effect found: the baseline fits within the noise (mean square 0.66 noise levels squared)"


def row(truth, findings, verdict, experiment="impact", seconds=10.0, **extra):
    return {"truth": truth, "findings": findings, "named": findings[0] if findings else "none", "verdict": verdict,
            "gap_removed": 0.9, "seconds": seconds, "experiment": experiment, "truth_set": "4",
            "run_seed": 7, "case": 0, "forms": True, "commit": "abc1234", **extra}


# Six impact rows: gear_play named right twice (once with a form beside it), missed once; "none" once with a
# form only (not a false alarm), once with an effect (a false alarm), once clean.
ROWS = [row("gear_play", ["gear_play"], WITHIN, seconds=10), row("gear_play", ["gear_play", "dahl_guide"],
                                                                    ROUNDS_WITHIN, seconds=30),
        row("gear_play", ["coating_relaxation"], LEFT, seconds=50), row("none", ["power_law_coating"], DIFFUSE),
        row("none", ["gear_play", "stiction"], ROUNDS_LEFT), row("none", [], FITS)]


def test_gap_left_is_read_from_every_verdict_that_leaves_one():
    assert [gap_left({"verdict": v}) for v in (WITHIN, LEFT, ROUNDS_LEFT, ROUNDS_WITHIN, DIFFUSE, FITS)] == \
        [False, True, True, False, True, False]


@pytest.mark.parametrize("k, n", [(0, 5), (5, 5), (3, 10), (13, 15)])
def test_wilson_interval_is_the_closed_form(k, n):
    z = 1.959963984540054
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * (p * (1 - p) / n + z * z / (4 * n * n)) ** 0.5 / (1 + z * z / n)
    assert wilson(k, n) == pytest.approx((centre - half, centre + half), abs=1e-12)


def test_counts_take_forms_apart_from_false_alarms():
    counts = count_rows(ROWS, shown=("gear_play",))
    assert counts["gear_play"]["named_right"] == 2 and counts["gear_play"]["gap_left"] == 1
    assert counts["gear_play"]["forms_named"] == 1
    assert counts["none"]["named_right"] == 2  # the form-only answer and the clean one
    su = counts["summary"]
    assert (su["false_alarms"], su["none_cases"], su["forms_on_none"]) == (1, 3, 1)
    assert (su["named_right_shown"], su["shown_cases"], su["gap_left"], su["cases"]) == (2, 3, 3, 6)


def test_tables_from_rows_write_the_experiment_and_overall_sections(tmp_path):
    rows_file = tmp_path / "rows.jsonl"
    slide = [row("stiction", ["stiction"], WITHIN, experiment="slide", seconds=70),
             row("none", [], FITS, experiment="slide", seconds=90)]
    rows_file.write_text("".join(json.dumps(r) + "\n" for r in ROWS + slide))
    doc = tmp_path / "validation.md"
    doc.write_text("".join(f"<!-- validation:{n} -->\n<!-- /validation:{n} -->\n"
                           for n in ("diagnose-impact-forms", "diagnose-slide-forms", "diagnose-summary-forms")))
    bench.tables_from_rows(rows_file, doc)
    text = doc.read_text()
    assert "| 4 | `gear_play` | 3 | 2/3 |" in text and "| 2/2 | 1 | 1 |" in text
    assert "| 4 | `stiction` | 1 | 1/1 |" in text
    # Over both: named right 3/4 shown, false alarms 1/4 "none", one form on "none", gaps left 3/8;
    # median times 10 s (impact: 10, 30, 50 and three of 10) and 80 s (slide: 70, 90).
    assert "| 4 | impact, slide | 3/4 |" in text and "| 1/4 |" in text
    assert "| 1 | 3/8 | impact 10 s, slide 80 s |" in text
    assert "8 rows, every one diagnosed at commit abc1234" in text and "target >= 70 %" in text


def test_tables_write_nothing_when_a_section_is_missing(tmp_path):
    rows_file = tmp_path / "rows.jsonl"
    rows_file.write_text("".join(json.dumps(r) + "\n" for r in ROWS))
    doc = tmp_path / "validation.md"
    before = "<!-- validation:diagnose-impact-forms -->\n<!-- /validation:diagnose-impact-forms -->\n"
    doc.write_text(before)
    with pytest.raises(SystemExit, match="expected one section <!-- validation:diagnose-summary-forms -->"):
        bench.tables_from_rows(rows_file, doc)
    assert doc.read_text() == before


def test_tables_refuse_rows_of_two_commits(tmp_path):
    rows_file = tmp_path / "rows.jsonl"
    rows_file.write_text(json.dumps(ROWS[0]) + "\n" + json.dumps({**ROWS[1], "commit": "def5678"}) + "\n")
    with pytest.raises(SystemExit, match="rows of 2 commits"):
        bench.tables_from_rows(rows_file)
