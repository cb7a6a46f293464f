"""Regenerate (or check) the example outputs of the guides in docs/guide/ by running their commands.

    python docs/guide/make_outputs.py [PAGE.md ...]           # run the commands, rewrite their outputs in the pages
    python docs/guide/make_outputs.py --check [PAGE.md ...]   # write nothing; exit 1 when a page drifted
    python docs/guide/make_outputs.py --check --fast          # skip the commands marked slow (minutes each)
    python docs/guide/make_outputs.py --only diagnose_speed.toml docs/guide/diagnose.md   # that command's blocks

A fenced block whose lines start with ``$ `` shows commands and what they print. The line before it says what to
do with it: ``<!-- output -->`` (run it), ``<!-- output: slow -->`` (run it unless ``--fast``: a diagnosis, a
calibration, a campaign) or ``<!-- output: not run: REASON -->`` (e.g. it needs the MSL in your home folder). A
``$`` block with none of these is an error, so no example escapes the check. ``<!-- file: PATH -->`` before a block
compares it with a file the page's commands wrote: a JSON file by its values, any other file by its lines (a
``...`` line in the block stands for lines left out). Wall and compile times differ from run to run and are not
compared (the summaries' ``wall_s``, ``wall_per_sim_s`` and ``compile_s``, ``... s wall``, ``loaded in ... s``).

The commands run in a temporary folder that links the checkout's folders (``examples``, ``fmus``, ...), so
``out/...`` is written there, never into yours; ``cosim`` and ``python -m`` run this checkout's Python and package.
"""

import argparse
import difflib
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

__all__ = ["check_page", "main"]

ROOT = Path(__file__).resolve().parents[2]
GUIDES = ROOT / "docs" / "guide"
# cosim and controllers are imported from the checkout itself (PYTHONPATH), so numba finds its cache of their kernels
LINKED = ("examples", "fmus", "modelica", "docs", "tests", "benchmarks", "pyproject.toml")
MARKER = re.compile(r"<!--\s*(output|file)(?::\s*(.*?))?\s*-->")
VOLATILE_KEYS = ("wall_s", "wall_per_sim_s", "compile_s")
VOLATILE = ((re.compile(r"[\d.e+-]+ s wall"), "<t> s wall"), (re.compile(r"loaded in [\d.e+-]+ s"), "loaded in <t> s"),
            (re.compile(r" in [\d.]+s( \(\d+:\d\d:\d\d\))?"), " in <t>s"), (re.compile(r"run in [\d.]+ s"), "run in <t> s"))
PROGRESS = re.compile(r"\d+%\|")  # a progress bar's line (tqdm), which the commands here do not draw


def _mask(text):
    for pattern, repl in VOLATILE:
        text = pattern.sub(repl, text)
    return [line.rstrip() for line in text.strip("\n").splitlines() if not PROGRESS.search(line)]


def _blocks(lines):
    """``(marker kind, marker argument, first line, end line)`` of every fenced block, with the marker on the last
    non-blank line before it (kind None when there is none)."""
    out, k = [], 0
    while k < len(lines):
        if lines[k].startswith("```"):
            end = next(j for j in range(k + 1, len(lines)) if lines[j].startswith("```"))
            prev = next((lines[j] for j in range(k - 1, -1, -1) if lines[j].strip()), "")
            m = MARKER.fullmatch(prev.strip())
            out.append((m.group(1) if m else None, (m.group(2) or "") if m else "", k + 1, end))
            k = end + 1
        else:
            k += 1
    return out


def _run(command, cwd):
    """What ``command`` (a ``$`` line) prints, stdout and stderr together, as a user's terminal shows it."""
    words = shlex.split(command)
    if words[0] == "cosim":
        words = [sys.executable, "-m", "cosim", *words[1:]]
    elif words[0] in ("python", "python3"):
        words = [sys.executable, *words[1:]]
    path = os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))
    env = {**os.environ, "PYTHONPATH": path, "COLUMNS": "80"}
    done = subprocess.run(words, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return _without_bars(done.stdout).rstrip("\n")


def _without_bars(text):
    """``text`` without its progress bars (each line as a terminal leaves it, after its last carriage return; a
    bar's lines and the blank lines it leaves dropped): what the command prints, not how long it took."""
    kept = []
    for line in text.split("\n"):
        shown = line.split("\r")[-1]
        if not PROGRESS.search(shown) and (shown.strip() or "\r" not in line and not (kept and not kept[-1].strip())):
            kept.append(shown)
    return "\n".join(kept).lstrip("\n")


def _commands(body):
    """``[(command, [shown output lines])]`` of a ``$`` block's lines."""
    pairs = []
    for line in body:
        if line.startswith("$ "):
            pairs.append((line[2:], []))
        elif pairs:
            pairs[-1][1].append(line)
    return pairs


def _file_problem(shown, path):
    """Why the block ``shown`` is not the file at ``path`` (None when it is)."""
    if not path.is_file():
        return f"{path.name} was not written"
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".json":
        def drop(d):
            return {k: v for k, v in d.items() if k not in VOLATILE_KEYS}
        want, got = drop(json.loads("\n".join(shown))), drop(json.loads(text))
        diff = {k for k in want.keys() | got.keys() if want.get(k) != got.get(k)}
        return f"keys differ: {', '.join(sorted(diff))}" if diff else None
    lines, at = _mask(text), 0
    chunks = [[]]
    for line in shown:
        chunks.append([]) if line.strip() == "..." else chunks[-1].append(line.rstrip())
    for chunk in filter(None, chunks):
        found = next((j for j in range(at, len(lines) - len(chunk) + 1) if lines[j:j + len(chunk)] == chunk), None)
        if found is None:
            return f"these lines are not in the file, in this order: {chunk[0]!r} ..."
        at = found + len(chunk)
    return None


def check_page(page, fast=False, write=True, log=print, only=None):
    """Run the commands of one guide page and compare (and with ``write``, rewrite) their outputs.

    Parameters
    ----------
    page : path-like
        A Markdown page.
    fast : bool, default False
        Skip the blocks marked slow (and the file blocks after them).
    write : bool, default True
        Rewrite the page's command outputs (and JSON file blocks) with what the commands printed.
    log : callable, default print
        Gets one line per block checked.
    only : str, optional
        Run only the blocks with a command holding this text (and the file blocks after them), e.g. one job's.

    Returns
    -------
    list of str
        The problems left: a block without a marker, an output or a file that differs (after ``write``, only what
        cannot be rewritten: an excerpt of a file).
    """
    page = Path(page)
    lines = page.read_text(encoding="utf-8").split("\n")
    problems, edits, skipped = [], [], False
    with tempfile.TemporaryDirectory(prefix="cosim-guide-") as tmp:
        for name in LINKED:
            if (ROOT / name).exists():
                os.symlink(ROOT / name, Path(tmp) / name)
        for kind, arg, first, end in _blocks(lines):
            body, where = lines[first:end], f"{page.name}:{first}"
            if kind is None:
                if any(line.startswith("$ ") for line in body):
                    problems.append((f"{where}: a $ block without <!-- output --> (or slow, or not run: why)", False))
                continue
            if kind == "output":
                other = only is not None and not any(only in command for command, _ in _commands(body))
                skipped = arg.startswith("not run") or (fast and arg == "slow") or other
                if skipped:
                    log(f"{where}: skipped ({f'not {only}' if other else arg})")
                    continue
                new = []
                for command, shown in _commands(body):
                    got = _run(command, tmp)
                    if _mask(got) != _mask("\n".join(shown)):
                        problems.append((f"{where}: `{command}` printed otherwise:\n" + "\n".join(difflib.unified_diff(
                            _mask("\n".join(shown)), _mask(got), "guide", "command", lineterm="", n=1)), True))
                    new += [f"$ {command}", *got.split("\n")]
                edits.append((first, end, new))
                log(f"{where}: ran {len(_commands(body))} command(s)")
            elif not skipped:
                problem = _file_problem(body, Path(tmp) / arg)
                fixable = problem is not None and arg.endswith(".json") and (Path(tmp) / arg).is_file()
                if fixable and write:
                    edits.append((first, end, (Path(tmp) / arg).read_text(encoding="utf-8").rstrip("\n").split("\n")))
                if problem:
                    problems.append((f"{where}: {arg}: {problem}", fixable))
                log(f"{where}: compared with {arg}")
    if write:
        for first, end, new in reversed(edits):
            lines[first:end] = new
        page.write_text("\n".join(lines), encoding="utf-8")
    return [text for text, fixable in problems if not (write and fixable)]


def main(argv=None):
    """The command line (see the module docstring); returns the exit status."""
    parser = argparse.ArgumentParser(description="Regenerate or check the guides' example outputs by running "
                                                 "their commands.")
    parser.add_argument("pages", nargs="*", type=Path, help="pages (default: every docs/guide/*.md)")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 when a page drifted")
    parser.add_argument("--fast", action="store_true", help="skip the commands marked slow")
    parser.add_argument("--only", metavar="TEXT", help="run only the blocks with a command holding TEXT, e.g. a job's "
                                                       "file name (and the file blocks after them)")
    args = parser.parse_args(argv)
    problems = []
    for page in args.pages or sorted(GUIDES.glob("*.md")):
        problems += check_page(page, fast=args.fast, write=not args.check, only=args.only)
    for problem in problems:
        print(problem, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
