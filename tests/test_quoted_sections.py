"""Every section the code and docs quote by name (README "X", docs/Y.md, "Z") is a heading of that file."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FOLDERS = ("lerobot_ivmc", "scripts", "benchmarks", "configs", "diagnostics", "docs")
FILES = ("README.md", "CHANGELOG.md")
SUFFIXES = {".py", ".md", ".yaml", ".yml", ".sh", ".toml", ".cfg", ".txt"}

# A file name (README, README.md or a path ending in .md), optionally `'s`, a comma or "section", then the
# quoted section name; the gap before the quote may break the line (a comment's `#` included).
REFERENCE = re.compile(
    r"(?<![\w./-])(?P<file>(?:[\w.-]+/)*[\w.-]+\.md|README)`?(?:'s)?,?(?:\s+section)?\s[\s#]*"
    r"[\"“](?P<section>[^\"”]{1,300}?)[\"”]"
)
HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*$")


def quoted_sections(text: str) -> list[tuple[str, str, int]]:
    """The (file, section, line) of each quoted section; a name broken over lines is joined with a space."""
    found = []
    for match in REFERENCE.finditer(text):
        section = re.sub(r"\s*\n\s*#?\s*", " ", match.group("section")).strip()
        found.append((match.group("file"), section, text.count("\n", 0, match.start()) + 1))
    return found


def headings(markdown: str) -> set[str]:
    """Every heading's text (any level, code blocks left out), without its #'s and surrounding spaces."""
    found, in_code = set(), False
    for line in markdown.splitlines():
        if line.startswith("```"):
            in_code = not in_code
        elif not in_code and (match := HEADING.match(line)):
            found.add(match.group(1))
    return found


def resolve(name: str, citing: Path) -> Path | None:
    """The quoted file: relative to the citing file's folder, else to the repository root."""
    name = "README.md" if name == "README" else name
    for base in (citing.parent, REPO):
        if (base / name).is_file():
            return base / name
    return None


def scanned_files() -> list[Path]:
    files = [REPO / name for name in FILES if (REPO / name).is_file()]
    for folder in FOLDERS:
        files += sorted(p for p in (REPO / folder).rglob("*") if p.suffix in SUFFIXES and p.is_file())
    return files


def test_the_pattern_finds_the_quoting_forms_and_not_prose() -> None:
    """The forms in use are found, a name that breaks a comment's line joined; plain quotes are not."""
    text = "\n".join(
        [
            'measured (README, "Sequence training": 6e-4)',
            'as in README "Benchmarks" and README\'s "Tests" section',
            'the limit (docs/RESULTS.md, "the perception\n    # check"), and pipeline.md "Did it work?"',
            'a `lerobot_ivmc/x.md`, "Layout" mention',
            'the label "BVMC" and the mode "window"; Path("README.md"), ".md", "x"',
            'README.md", f"{x}" and table.md` shows it as "failures (flagged)"',
        ]
    )
    assert quoted_sections(text) == [
        ("README", "Sequence training", 1),
        ("README", "Benchmarks", 2),
        ("README", "Tests", 2),
        ("docs/RESULTS.md", "the perception check", 3),
        ("pipeline.md", "Did it work?", 4),
        ("lerobot_ivmc/x.md", "Layout", 5),
    ]


def test_quoted_sections_exist() -> None:
    """Each quoted section is a heading of the file it names, compared exactly."""
    checked, broken, cache = 0, [], {}
    for path in scanned_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for name, section, line in quoted_sections(text):
            where = f'{path.relative_to(REPO)} line {line}: {name} "{section}"'
            target = resolve(name, path)
            if target is None:
                broken.append(f"{where} (no such file)")
                continue
            if target not in cache:
                cache[target] = headings(target.read_text(encoding="utf-8"))
            if section not in cache[target]:
                broken.append(f"{where} (no such heading in {target.relative_to(REPO)})")
            checked += 1
    assert checked, "no quoted section found: the pattern no longer matches the files"
    assert not broken, "\n".join(broken)
