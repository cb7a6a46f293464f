"""Run (or check) the Python blocks of a guide: docs/guide/python.md's code is what the package does.

    python docs/guide/run_python.py --check [PAGE.md]   # run the blocks; exit 1 when one fails or prints otherwise
    python docs/guide/run_python.py [PAGE.md]           # run them, rewrite what they print and copy their plots

Every ```` ```python ```` block of the page runs, in order and in one namespace, in a temporary folder that links
the checkout's ``modelica/`` and holds a copy of its ``examples/`` (so the configs' ``../fmus`` is the folder's own
``fmus/``, which the page builds): nothing is written into the checkout. A block followed by an ```` ```output ````
block must print exactly that. The images the page shows (``![...](NAME.png)``) are the files the blocks wrote;
without ``--check`` they are copied beside the page.
"""

import argparse
import contextlib
import io
import os
import re
import shutil
import sys
import tempfile
import traceback
from pathlib import Path

__all__ = ["run_page", "main"]

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "guide" / "python.md"
FENCE = re.compile(r"^```(\w*)\s*$")
IMAGE = re.compile(r"!\[[^\]]*\]\(([^)/]+\.png)\)")


def _blocks(lines):
    """``(language, first line, end line)`` of every fenced block (``lines[first:end]`` its body)."""
    out, k = [], 0
    while k < len(lines):
        m = FENCE.match(lines[k])
        if m:
            end = next(j for j in range(k + 1, len(lines)) if lines[j].startswith("```"))
            out.append((m.group(1), k + 1, end))
            k = end + 1
        else:
            k += 1
    return out


def _folder(tmp):
    """The folder the blocks run in: the checkout's Modelica sources linked, its examples copied."""
    (tmp / "modelica").symlink_to(ROOT / "modelica", target_is_directory=True)
    shutil.copytree(ROOT / "examples", tmp / "examples", ignore=shutil.ignore_patterns("__pycache__"))


def run_page(page=PAGE, write=False, log=print):
    """Run the page's Python blocks; return the problems (a block that raised, or printed otherwise).

    With ``write``, the ``output`` blocks are rewritten with what was printed and the page's images copied from
    what the blocks wrote (only when every block ran and wrote the images: what they printed is then no
    problem)."""
    import matplotlib

    matplotlib.use("Agg")
    page = Path(page)
    lines = page.read_text(encoding="utf-8").split("\n")
    blocks = _blocks(lines)
    problems, drifts, edits, namespace = [], [], [], {"__name__": "__guide__"}
    here = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="cosim-guide-") as tmp:
        _folder(Path(tmp))
        os.chdir(tmp)
        try:
            for i, (language, first, end) in enumerate(blocks):
                if language != "python":
                    continue
                printed = io.StringIO()
                try:
                    with contextlib.redirect_stdout(printed):
                        exec(compile("\n".join(lines[first:end]), f"{page.name}:{first}", "exec"), namespace)
                except Exception:
                    problems.append(f"{page.name}:{first}: the block raised:\n{traceback.format_exc(limit=-3)}")
                    break
                shown = blocks[i + 1] if i + 1 < len(blocks) and blocks[i + 1][0] == "output" else None
                got = printed.getvalue().rstrip("\n").split("\n")
                if shown is not None and lines[shown[1]:shown[2]] != got:
                    drifts.append(f"{page.name}:{first}: printed\n" + "\n".join(got) + "\nnot what the page shows\n"
                                  + "\n".join(lines[shown[1]:shown[2]]))
                    edits.append((shown[1], shown[2], got))
                log(f"{page.name}:{first}: ran")
            images = IMAGE.findall("\n".join(lines))
            problems += [f"{page.name}: the blocks did not write {name}, which the page shows" for name in images
                         if not (Path(tmp) / name).is_file()]
            if write and not problems:
                for name in images:
                    shutil.copyfile(Path(tmp) / name, page.parent / name)
                for first, end, new in reversed(edits):
                    lines[first:end] = new
                page.write_text("\n".join(lines), encoding="utf-8")
        finally:
            os.chdir(here)
    return problems if write and not problems else problems + drifts


def main(argv=None):
    """The command line (see the module docstring); returns the exit status."""
    parser = argparse.ArgumentParser(description="Run (or check) the Python blocks of a guide.")
    parser.add_argument("page", nargs="?", type=Path, default=PAGE, help="the page (default: docs/guide/python.md)")
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit 1 when a block fails or prints what the page does not show")
    args = parser.parse_args(argv)
    problems = run_page(args.page, write=not args.check)
    for problem in problems:
        print(problem, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
