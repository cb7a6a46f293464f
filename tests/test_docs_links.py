"""Every relative link in the user docs and the README reaches a file, and every ``#anchor`` into a Markdown page
reaches one of its headings (GitHub's rule for heading anchors), so a renamed section cannot leave a dead link."""
import functools
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md"]
LINK = re.compile(r"\]\(([^)#\s]*)(?:#([^)\s]+))?\)")


def heading_anchor(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped but for hyphens, spaces made hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


@functools.cache
def anchors(page):
    """The anchors of ``page``'s headings, outside fenced code (read once a page, however many links name it)."""
    found, fenced = set(), False
    for line in page.read_text().splitlines():
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced and line.startswith("#"):
            found.add(heading_anchor(line.lstrip("#")))
    return found


def links(page):
    """(line number, target path, anchor or None) of every relative link on ``page``."""
    for number, line in enumerate(page.read_text().splitlines(), 1):
        for target, anchor in LINK.findall(line):
            if not target.startswith(("http:", "https:", "mailto:")):
                yield number, target, anchor or None


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_and_anchors_resolve(page):
    dead = []
    for number, target, anchor in links(page):
        path = (page.parent / target).resolve() if target else page
        if not path.exists():
            dead.append(f"{page.relative_to(ROOT)}:{number}: {target} does not exist")
        elif anchor and path.suffix == ".md" and anchor not in anchors(path):
            dead.append(f"{page.relative_to(ROOT)}:{number}: {target}#{anchor} names no heading of {path.name}")
    assert not dead, "\n".join(dead)


def test_heading_anchor_follows_githubs_rule():
    assert heading_anchor(" Modelica Standard Library examples against the reference results") == \
        "modelica-standard-library-examples-against-the-reference-results"
    assert heading_anchor("Diagnosis with forms of laws, in rounds: the fourth truth") == \
        "diagnosis-with-forms-of-laws-in-rounds-the-fourth-truth"
    assert heading_anchor("`cosim run`: options") == "cosim-run-options"
