"""The sources say their rules themselves: no docstring or comment cites a design file that is not
in the repository, or an issue by its number, in the package, the tests, the benchmarks' code or
the tutorials. (The benchmarks' README keeps its history, issue numbers included.)"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CITATION = re.compile(r"DESIGN\.md|\b[Ii]ssues? +#?\d+|\b(?:as )?the issue(?:'s)?\b|(?<![\w&])#\d+\b")


def test_no_source_cites_a_design_file_or_an_issue():
    sources = [
        path
        for folder in ("drake_sot", "tests", "benchmarks", "tutorials", "examples")
        for path in sorted((ROOT / folder).rglob("*.py"))
        if path != Path(__file__).resolve()  # its pattern would match itself
    ]
    assert len(sources) > 100, f"found only {len(sources)} sources under {ROOT}"
    found = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in sources
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)
        if CITATION.search(line)
    ]
    assert not found, "\n".join(found)
