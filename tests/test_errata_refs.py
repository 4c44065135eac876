"""`ERRATA n` citations and docs/errata.md: every cited number has a section, every section real files.

The code cites the paper's errata by number ("ERRATA 12", "ERRATA 4-5", "ERRATA 11, 16").
docs/errata.md is where those numbers are defined; these tests keep the two in step.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ERRATA_DOC = ROOT / "docs" / "errata.md"

# Where citations are collected: (directory or file, glob); suffixes limit it to text files.
SCANNED = (
    ("src", "**/*.py"),
    ("README.md", ""),
    ("docs", "*.md"),
    ("notebooks", "*.ipynb"),
    ("benchmarks", "**/*"),
    ("urdf", "**/*"),
    ("examples", "*.toml"),
    ("tests", "**/*.py"),
)
TEXT_SUFFIXES = {".py", ".md", ".ipynb", ".urdf", ".toml", ".json", ".txt"}

# "ERRATA 7", "ERRATA 4-5" (a range), "ERRATA 7, 9, 10", "ERRATA 13/14", "ERRATA 2 and 6".
_CITATION = re.compile(r"\bERRATA\s+(\d+(?:\s*(?:[-\u2013]|,|/|\band\b)\s*\d+)*)")
_ITEM = re.compile(r"(\d+)(?:\s*[-\u2013]\s*(\d+))?")
_HEADING = re.compile(r"^## ERRATA (\d+): (\S.*)$", re.MULTILINE)
_PATH = re.compile(r"^((?:src|tests|urdf|docs|benchmarks|notebooks|examples)/[\w./-]+?)(?:::(\w+))?$")


def cited_numbers(text: str) -> list[int]:
    """Every erratum number cited in ``text``, in order; a range n-m cites n, n+1, ..., m."""
    numbers = []
    for match in _CITATION.finditer(text):
        for item in _ITEM.finditer(match.group(1)):
            first = int(item.group(1))
            last = int(item.group(2)) if item.group(2) else first
            assert first <= last, f"reversed range in {match.group(0)!r}"
            numbers.extend(range(first, last + 1))
    return numbers


def _notebook_text(path: Path) -> str:
    """Every string of a notebook (cell sources and outputs), so JSON escapes cannot hide a citation."""
    strings: list[str] = []

    def walk(node: object) -> None:
        if isinstance(node, str):
            strings.append(node)
        elif isinstance(node, list):
            for child in node:
                walk(child)
        elif isinstance(node, dict):
            for child in node.values():
                walk(child)

    walk(json.loads(path.read_text(encoding="utf-8")))
    return "".join(strings)


def scanned_files() -> list[Path]:
    files = []
    for where, pattern in SCANNED:
        base = ROOT / where
        candidates = [base] if not pattern else sorted(base.glob(pattern))
        files += [
            p
            for p in candidates
            if p.is_file() and p.suffix in TEXT_SUFFIXES and p.resolve() != Path(__file__).resolve()
        ]
    return files


def citations() -> dict[int, list[str]]:
    """Cited erratum number -> the places citing it ("path:line")."""
    found: dict[int, list[str]] = {}
    for path in scanned_files():
        rel = path.relative_to(ROOT).as_posix()
        if path.suffix == ".ipynb":
            lines = _notebook_text(path).splitlines()
        else:
            lines = path.read_text(encoding="utf-8").splitlines()
        for lineno, line in enumerate(lines, start=1):
            if _HEADING.match(line):  # a section heading of docs/errata.md defines, it does not cite
                continue
            for n in cited_numbers(line):
                found.setdefault(n, []).append(f"{rel}:{lineno}")
    return found


def sections() -> dict[int, tuple[str, str]]:
    """docs/errata.md: number -> (title, body up to the next heading), in file order."""
    text = ERRATA_DOC.read_text(encoding="utf-8")
    heads = list(_HEADING.finditer(text))
    out = {}
    for i, head in enumerate(heads):
        end = heads[i + 1].start() if i + 1 < len(heads) else len(text)
        out[int(head.group(1))] = (head.group(2), text[head.end() : end])
    return out


def test_citation_parser_expands_ranges_and_lists():
    text = "(ERRATA 4-5) ERRATA 1-3, 16; ERRATA 7, 9, 10 | ERRATA 13/14 ERRATA 2 and 6 ERRATA 12: and 8"
    assert cited_numbers(text) == [4, 5, 1, 2, 3, 16, 7, 9, 10, 13, 14, 2, 6, 12]
    assert cited_numbers("ERRATA 9). 200 runs; ERRATA n; errata 3; ERRATA.md") == [9]
    assert cited_numbers("ERRATA 2\u20134") == [2, 3, 4]


def test_the_scan_finds_the_repository_citations():
    found = citations()
    places = sum(len(v) for v in found.values())
    assert places > 100, f"only {places} citations found: is the scan looking in the right places?"
    assert "src/ibvs_youla/control/inner.py" in {p.rsplit(":", 1)[0] for p in found[8]}
    assert any(p.startswith("notebooks/") for p in found[13])
    assert any(p.startswith("urdf/") for p in found[16])
    assert {4, 5} <= found.keys()  # only ever cited as the range "ERRATA 4-5"


def test_every_cited_erratum_has_a_section():
    defined = sections()
    missing = {n: places for n, places in citations().items() if n not in defined}
    assert not missing, "cited without a '## ERRATA n:' section in docs/errata.md: " + "; ".join(
        f"ERRATA {n} at {', '.join(places[:5])}" for n, places in sorted(missing.items())
    )


def test_headings_are_numbered_one_to_n_without_gaps():
    text = ERRATA_DOC.read_text(encoding="utf-8")
    numbers = [int(m.group(1)) for m in _HEADING.finditer(text)]
    assert numbers == list(range(1, len(numbers) + 1)), f"headings in order 1..N expected: {numbers}"
    assert len(numbers) >= 16
    # no heading that looks like an erratum but escapes the exact form
    loose = [line for line in text.splitlines() if line.startswith("#") and "ERRATA" in line]
    assert len(loose) == len(numbers), [line for line in loose if not _HEADING.match(line)]


def test_each_section_names_existing_files_and_test_functions():
    for n, (title, body) in sections().items():
        refs = [m for m in (_PATH.match(token) for token in re.findall(r"`([^`\n]+)`", body)) if m]
        in_repo = [m for m in refs if m.group(1).startswith(("src/", "tests/"))]
        assert in_repo, f"ERRATA {n} ({title}) names no path under src/ or tests/"
        for m in refs:
            path = ROOT / m.group(1)
            assert path.is_file(), f"ERRATA {n}: {m.group(1)} does not exist"
            if m.group(2):  # path::name, a test function or a class in that file
                pattern = rf"^\s*(?:def|class)\s+{m.group(2)}\b"
                assert re.search(pattern, path.read_text(encoding="utf-8"), re.MULTILINE), (
                    f"ERRATA {n}: {m.group(1)} defines no {m.group(2)}"
                )


def test_each_section_says_what_the_paper_prints_and_which_tests_pin_it():
    for n, (title, body) in sections().items():
        for label in ("**Paper:**", "**Used instead:**", "**Code:**", "**Tests:**"):
            assert label in body, f"ERRATA {n} ({title}) has no {label}"
        tests_part = body.split("**Tests:**", 1)[1]
        named = "`tests/" in tests_part or "no test" in tests_part
        assert named, f"ERRATA {n}: the Tests part neither names a test nor says there is none"
