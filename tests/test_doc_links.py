"""Every link in the project's Markdown (README, CHANGELOG, docs/) leads somewhere: a relative
link to a file that exists, and a ``#fragment`` to a heading of the page it names, by the
anchors GitHub gives headings."""

from __future__ import annotations

import collections
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted([ROOT / "README.md", ROOT / "CHANGELOG.md", *(ROOT / "docs").rglob("*.md")])
FENCE = re.compile(r"^```.*?^```", re.S | re.M)
LINK = re.compile(r"\]\(([^)\s]+)\)")


def anchors(text: str) -> set[str]:
    """The anchors of a page's headings as GitHub makes them: lower case, every character but
    letters, digits, ``_``, ``-`` and spaces dropped, spaces as ``-``; a repeated one gets
    ``-1``, ``-2``..."""
    seen: collections.Counter[str] = collections.Counter()
    out = set()
    for line in FENCE.sub("", text).splitlines():
        m = re.match(r"^#{1,6} (.*?)\s*$", line)
        if not m:
            continue
        slug = re.sub(r"[^\w\- ]", "", m.group(1).lower()).replace(" ", "-")
        out.add(f"{slug}-{seen[slug]}" if seen[slug] else slug)
        seen[slug] += 1
    return out


def broken(page: Path) -> list[str]:
    """The links of ``page`` that lead nowhere."""
    out = []
    for target in LINK.findall(FENCE.sub("", page.read_text(encoding="utf-8"))):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto:: not checked here
            continue
        path, _, fragment = target.partition("#")
        dest = (page.parent / path) if path else page
        if not dest.exists():
            out.append(f"{target} (no such file)")
        elif fragment and dest.suffix == ".md":
            if fragment not in anchors(dest.read_text(encoding="utf-8")):
                out.append(f"{target} (no such heading)")
    return out


def test_the_checker_finds_a_missing_file_and_a_missing_heading(tmp_path: Path) -> None:
    (tmp_path / "b.md").write_text("# B\n\n## Size × 2, again\n\n## Size × 2, again\n")
    page = tmp_path / "a.md"
    page.write_text(
        "# A\n\n## Où\n[ok](b.md#size--2-again) [ok](b.md#size--2-again-1) [ok](#où)\n"
        "[no](b.md#size-2-again) [no](c.md) [no](#a-1) [web](https://x.org/#no)\n"
        "```\n[in code](#nowhere)\n```\n"
    )
    assert broken(page) == [
        "b.md#size-2-again (no such heading)",
        "c.md (no such file)",
        "#a-1 (no such heading)",
    ]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_link_of_the_docs_leads_somewhere(page: Path) -> None:
    assert broken(page) == []
