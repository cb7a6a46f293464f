"""A fit in progress says its iteration, cost, step and time left (issue #44 item 7): the calibration's IPOPT and
least-squares fits, in this process and on Dask workers, through ``cosim calibrate``."""

import re

import pytest
from test_calibrate import experiment, msd, synthetic_msd, write_job  # noqa: F401

from cosim.calibrate import Calibrator
from cosim.cli import main

LINE = re.compile(r"(it|eval) (\d+)/(\d+)  cost (\S+)  step (\S+)  (\S+) s/(it|eval)  ETA <= \d+(\.\d)? (s|min|h)")
FREE = {"k": (150.0, 10.0, 1000.0), "d": (3.0, 0.01, 10.0)}


def _parsed(lines):
    rows = [LINE.fullmatch(line) for line in lines]
    assert all(rows), lines
    return [(int(m.group(2)), int(m.group(3)), float(m.group(4))) for m in rows]


def test_ipopt_fit_reports_each_iteration_to_the_optimum(msd):  # noqa: F811
    lines = []
    fit = Calibrator(msd, ["x"], FREE, substeps=10, max_iter=50, progress=lines.append)
    fit.fit(experiment(*synthetic_msd(3.0)))
    rows = _parsed(lines)
    counts = [n for n, _, _ in rows]
    assert counts == sorted(counts) and rows[0][0] == 1 and all(limit == 50 for _, limit, _ in rows)
    # IPOPT calls back at its start point and after each of its iterations; the last line is the optimum's cost
    assert rows[-1][0] == fit.iterations_ + 1
    assert rows[-1][2] == pytest.approx(fit.cost_after_, rel=1e-3)
    assert rows[0][2] == pytest.approx(fit.cost_before_, rel=1e-3)


def test_least_squares_fit_reports_evaluations_and_its_lowest_cost(msd):  # noqa: F811
    lines = []
    fit = Calibrator(msd, ["x"], FREE, method="single_shooting", max_iter=30, progress=lines.append)
    fit.fit(experiment(*synthetic_msd(3.0)))
    rows = _parsed(lines)
    assert rows[0][2] == pytest.approx(fit.cost_before_, rel=1e-3)
    assert rows[-1][2] == pytest.approx(fit.cost_after_, rel=1e-3)
    assert all(a[2] >= b[2] for a, b in zip(rows, rows[1:]))  # the lowest cost so far never rises


def test_cosim_calibrate_shows_the_fit_beside_its_bar(tmp_path, capsys):
    assert main(["calibrate", str(write_job(tmp_path)), "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert re.search(r"fit: .*#1 it \d+/200  cost \S+  step \S+  \S+ s/it  ETA <= ", err), err[-2000:]


@pytest.mark.slow
def test_multistart_workers_send_their_progress_to_the_bar(tmp_path, capsys):
    job = write_job(tmp_path, extra="\n[multistart]\ncount = 2\nseed = 7\n")
    assert main(["calibrate", str(job), "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert re.search(r"multi-start fits: .*#[12] it \d+/200  cost \S+", err), err[-2000:]
