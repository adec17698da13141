"""The README and the reference docs state what is true now; history lives in docs/notes/
(issue 40). This check fails when a reference page names a tuning round, a try, a session,
a commit hash or a CI run: the marks of a lab notebook. docs/notes/ and CHANGELOG.md are
exempt; so are file names (a raw-data file may carry the commit it was measured on)."""
import re

REFERENCE_GLOBS = ["README.md", "BENCHMARKS.md", "docs/*.md", "urdf/README.md", "bench/reference/README.md", "examples/**/*.md"]

# Each pattern names one kind of history, so a failure says which.
HISTORY = {
    "a tuning round": re.compile(r"(?<!--)\brounds? \d+", re.I),
    "a numbered try": re.compile(r"\btry \d+", re.I),
    "a session": re.compile(r"\bsession \d+|\b(this|last|earlier|previous) session\b", re.I),
    "a CI story": re.compile(r"\bCI (run|runs|failed|failure|passed)\b|\bflak(y|e)\b", re.I),
    "a branch of the team's work": re.compile(r"\bbranch `[a-z0-9]+`|\bthe `[a-z0-9]+` branch\b|\bbranch's `"),
    "a numbered round by name": re.compile(r"\b(first|second|third|fourth|fifth|sixth|last|earlier|previous) (round|sweep)s?\b", re.I),
    "a dated change": re.compile(r"\b(until|since|before|after) 20\d\d-\d\d-\d\d\b", re.I),
    "the history of a rule": re.compile(r"\b(until|since|before) issue \d+\b", re.I),
}
# A commit hash: 7-40 hex digits with at least one letter and one digit, not inside a path or file name.
# A source's version (an upstream repository's commit next to its github.com address) is provenance,
# not history: a line with such an address, or right after one, is exempt.
HASH = re.compile(r"(?<![\w./-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}(?![\w./-])")


def pages(root):
    seen = set()
    for g in REFERENCE_GLOBS:
        for p in sorted(root.glob(g)):
            if p.is_file() and p not in seen and "notes" not in p.parts:
                seen.add(p)
                yield p


def findings(text):
    out = []
    prev = ""
    for n, line in enumerate(text.splitlines(), 1):
        upstream = "github.com/" in line or "github.com/" in prev
        prev = line
        for what, rx in HISTORY.items():
            m = rx.search(line)
            if m:
                out.append((n, what, m.group(0)))
        for m in HASH.finditer("" if upstream else line):
            out.append((n, "a commit hash", m.group(0)))
    return out


def test_the_check_sees_history_when_it_is_there():
    sample = "Tuned in round 13 on 0a0ad4b; the CI run failed, fixed in try 4 (session 7)."
    kinds = {k for _, k, _ in findings(sample)}
    assert kinds == {"a tuning round", "a numbered try", "a session", "a CI story", "a commit hash"}, kinds
    sample = "The second round (the `inert14` branch) fixed it; until 2026-12-03 it failed, as it did until issue 38."
    kinds = {k for _, k, _ in findings(sample)}
    assert kinds == {"a numbered round by name", "a branch of the team's work", "a dated change", "the history of a rule"}, kinds
    # ... and not where there is none: a file name with a hash, a hex colour, a word with hex letters.
    assert findings("raw JSON `bench/chain/quiet_600s_6d79da4.json`, colour ffffff, a decade 2026") == []
    assert findings("`multihost.py --rounds 2`; github.com/yinzikang/torque-control at commit b77be752eb0a") == []


def test_reference_docs_carry_no_history(root):
    found = list(pages(root))
    assert any(p.name == "README.md" for p in found) and any(p.parent.name == "docs" for p in found), found
    bad = [f"{p.relative_to(root)}:{n}: {what} ({tok!r})" for p in found for n, what, tok in findings(p.read_text())]
    assert not bad, "history in reference docs (move it to docs/notes/):\n" + "\n".join(bad)


def doc_comment_lines(root):
    """Rust doc comments (`///`, `//!`) of the project's own crates (issue 40: a docstring
    says what and why; the history of a value goes to the notes). Vendored code is exempt."""
    for top in ("crates", "nodes", "cli"):
        for p in sorted((root / top).rglob("*.rs")):
            if "vendor" in p.parts or "target" in p.parts:
                continue
            for n, line in enumerate(p.read_text().splitlines(), 1):
                s = line.lstrip()
                if s.startswith("///") or s.startswith("//!"):
                    yield p, n, s


def test_docstrings_carry_no_tuning_history(root):
    kinds = ("a tuning round", "a numbered try", "a session")
    seen = 0
    bad = []
    for p, n, s in doc_comment_lines(root):
        seen += 1
        for what in kinds:
            m = HISTORY[what].search(s)
            if m:
                bad.append(f"{p.relative_to(root)}:{n}: {what} ({m.group(0)!r})")
    assert seen > 1000, f"only {seen} doc-comment lines found: is the tree where the test looks?"
    assert not bad, "tuning history in docstrings (move it to docs/notes/):\n" + "\n".join(bad)


def test_readme_and_controller_page_stay_short(root):
    """Issue 40's bounds: the README is a front page (≤ 150 lines, ≤ 8 KB), the controller
    page a reference (≤ 600 lines); detail goes to the other docs/ pages."""
    readme = (root / "README.md").read_bytes()
    lines = readme.count(b"\n")
    assert lines <= 150, f"README.md has {lines} lines (at most 150): move detail to docs/"
    assert len(readme) <= 8 * 1024, f"README.md is {len(readme)} bytes (at most 8 KB): move detail to docs/"
    ctrl = (root / "docs" / "controller.md").read_text().splitlines()
    assert len(ctrl) <= 600, f"docs/controller.md has {len(ctrl)} lines (at most 600)"


def test_every_note_is_in_the_docs_index(root):
    """The lab notebook is kept apart but findable: each note is linked from docs/README.md."""
    index = (root / "docs" / "README.md").read_text()
    notes = sorted((root / "docs" / "notes").glob("*.md"))
    assert notes, "docs/notes/ has no notes: the check has nothing to look at"
    missing = [n.name for n in notes if f"notes/{n.name}" not in index]
    assert not missing, "notes not linked from docs/README.md (add a row to its notes table): " + ", ".join(missing)
