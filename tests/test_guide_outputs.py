"""The guides' example outputs are what the commands print (issue #44 item 8): ``docs/guide/make_outputs.py``
regenerates them and, with ``--check``, fails when a page drifted; the help texts the reference is made of."""

import importlib.util
import subprocess
import sys
import textwrap

import pytest

from cosim.cli import main
from test_master_support import ROOT

MAKE_CLI = ROOT / "docs" / "reference" / "make_cli.py"
MAKE_PYTHON = ROOT / "docs" / "reference" / "make_python.py"


def _module(path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


make_outputs = _module(ROOT / "docs" / "guide" / "make_outputs.py")
run_python = _module(ROOT / "docs" / "guide" / "run_python.py")
# a guide's block whose command prints otherwise than shown
DRIFTED = '<!-- output -->\n```\n$ python3 -c "print(6 * 7)"\n41\n```\n'


def test_a_drifted_output_fails_the_check_and_is_rewritten(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(DRIFTED)
    problems = make_outputs.check_page(page, write=False, log=lambda line: None)
    assert len(problems) == 1 and "printed otherwise" in problems[0] and "+42" in problems[0]
    assert make_outputs.check_page(page, log=lambda line: None) == []
    assert "$ python3 -c \"print(6 * 7)\"\n42\n```" in page.read_text()
    assert make_outputs.check_page(page, write=False, log=lambda line: None) == []


def test_a_command_block_without_a_marker_is_an_error(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```\n$ cosim --version\ncosim 0\n```\n")
    problems = make_outputs.check_page(page, write=False, log=lambda line: None)
    assert problems == ["page.md:1: a $ block without <!-- output --> (or slow, or not run: why)"]


@pytest.mark.slow
def test_the_guides_fast_examples_print_what_the_guides_show():
    # The guides' commands run in the checkout after the README's set-up, which includes `cosim build` (a fresh
    # clone has no fmus/; the build writes each FMU atomically and skips the up-to-date ones).
    assert main(["build"]) == 0
    assert main(["build", "examples/ssp/Oscillators.mo", "--model", "Oscillators.Body", "--fmi-version", "2",
                 "--out", "examples/ssp/fmus"]) == 0  # docs/guide/ssp.md's first step
    # the slow ones (diagnose, calibrate, campaign, haptic margins): python docs/guide/make_outputs.py --check
    assert make_outputs.main(["--check", "--fast"]) == 0


def test_a_python_block_that_fails_or_prints_otherwise_fails_the_check(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```python\nx = 6 * 7\nprint(x)\n```\n\n```output\n41\n```\n\n```python\nprint(x / 0)\n```\n"
                    "\n```python\nprint('not run')\n```\n")
    problems = run_python.run_page(page, log=lambda line: None)
    assert len(problems) == 2 and problems[0].startswith("page.md:10: the block raised")
    assert "ZeroDivisionError" in problems[0] and problems[1] == "page.md:1: printed\n42\nnot what the page shows\n41"


@pytest.mark.slow
def test_the_python_guide_runs_as_written():
    # builds the GripperPlant twice (FMI 3 and 2) into a temporary folder and runs the impact six times
    assert run_python.run_page(log=lambda line: None) == []


def test_only_runs_the_blocks_of_the_command_asked_for(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(DRIFTED + textwrap.dedent("""\
        <!-- output: slow -->
        ```
        $ python3 -c "print(2 + 2)"
        4
        ```
        """))
    lines = []
    assert make_outputs.check_page(page, write=False, log=lines.append, only="2 + 2") == []
    assert lines == ['page.md:2: skipped (not 2 + 2)', "page.md:7: ran 1 command(s)"]
    assert len(make_outputs.check_page(page, write=False, log=lambda line: None, only="6 * 7")) == 1


# The diagnoses of docs/guide/diagnose.md whose answer the suite checks (a refactor that changes an answer fails
# here): each job runs as the guide shows it, and what it prints and the report's lines shown are compared. CPU
# time on the 2-core machine: speed 57 s, impact 30 s, haptic 6 s. The rounds and the several experiments (minutes
# each): python docs/guide/make_outputs.py --check; the static curve (over 6 min of CPU) is shown by none.
GUIDE_DIAGNOSES = ("diagnose_speed.toml", "diagnose_impact.toml", "diagnose_haptic.toml")


@pytest.mark.slow
@pytest.mark.parametrize("job", GUIDE_DIAGNOSES)
def test_the_diagnose_guide_shows_what_its_job_answers(job):
    done = []
    assert make_outputs.check_page(ROOT / "docs" / "guide" / "diagnose.md", write=False, log=done.append,
                                   only=f"examples/{job}") == []
    assert [line for line in done if line.endswith("ran 1 command(s)")], f"diagnose.md runs no {job}"


def test_make_cli_help_prints_help_and_writes_nothing():
    page = ROOT / "docs" / "reference" / "cli.md"
    before = page.read_bytes()
    done = subprocess.run([sys.executable, str(MAKE_CLI), "--help"], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.startswith("usage: make_cli.py") and "--check" in done.stdout
    assert page.read_bytes() == before


@pytest.mark.slow
def test_cli_reference_is_what_the_commands_print():
    assert subprocess.run([sys.executable, str(MAKE_CLI), "--check"]).returncode == 0


def test_python_reference_is_what_the_docstrings_say():
    page = ROOT / "docs" / "reference" / "python.md"
    before = page.read_bytes()
    done = subprocess.run([sys.executable, str(MAKE_PYTHON), "--check"], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert page.read_bytes() == before and "cosim.run(config, *, set=None" in before.decode()


def test_haptic_help_describes_its_four_subcommands(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["haptic", "--help"])
    assert stop.value.code == 0
    description = capsys.readouterr().out.split("positional arguments")[0]
    for name in ("margins", "collisions", "identify", "arm"):
        assert f"({name})" in description
