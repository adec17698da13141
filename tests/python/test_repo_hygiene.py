"""Repository hygiene: no committed file names an absolute path of a
development machine (issue 17: a `source:` line once carried one)."""
import re
import subprocess

# Home and work directories of the machines this project is developed and
# tested on, and of the usual desktop systems; and /tmp paths baked in (a venv or
# a build left in /tmp on one machine). A /tmp folder given as an output flag's
# value (`--out /tmp/run`) is the user's scratch choice in an example, not a
# machine path, and is allowed.
MACHINE_PATH = re.compile(r"(?<![\w.~-])/(?:work|root|home|Users|tmp)/[\w.-]")
OUTPUT_FLAG_BEFORE = re.compile(r"--out(?:-dir)?[ =]$")


def machine_paths(line):
    """The machine-specific absolute paths in one line of text."""
    return [m.group(0) for m in MACHINE_PATH.finditer(line)
            if not (m.group(0).startswith("/tmp/") and OUTPUT_FLAG_BEFORE.search(line[:m.start()]))]


def tracked_text_files(root):
    out = subprocess.run(["git", "ls-files", "-z"], cwd=root, capture_output=True, check=True).stdout
    for name in out.decode().split("\0"):
        if not name:
            continue
        path = root / name
        try:
            data = path.read_bytes()
        except (FileNotFoundError, IsADirectoryError):
            continue  # deleted in the work tree, or a submodule
        if b"\0" in data[:8192]:
            continue  # binary
        yield name, data.decode("utf-8", errors="replace")


def test_the_pattern_catches_machine_paths_and_spares_relative_ones():
    assert machine_paths("source: 'naic explain on /work/shared/data/x.csv'")
    assert machine_paths("cd /root/.cargo")
    assert machine_paths("/home/alice/robot.urdf")
    assert machine_paths("NAIC_VENV=/tmp/venv bash build.sh")
    assert machine_paths('unwrap_or_else(|_| "/tmp/venv/bin/python".into())')
    assert machine_paths("naic sim --out /tmp/run --urdf /tmp/x/jk5.urdf") == ["/tmp/x"]
    assert not machine_paths("../shared/data/jk5-friction/x.csv")
    assert not machine_paths("--out /tmp/run")
    assert not machine_paths("naic bench --out-dir=/tmp/b")
    assert not machine_paths("crates/naic_core/src/work/x.rs")
    assert not machine_paths("std::env::temp_dir() /tmp")


def test_no_committed_file_names_an_absolute_machine_path(root):
    files = list(tracked_text_files(root))
    assert len(files) > 100, f"git ls-files listed only {len(files)} text files: is this a git checkout?"
    hits = []
    for name, text in files:
        if name == "tests/python/test_repo_hygiene.py":
            continue  # the patterns above are examples, not paths
        for n, line in enumerate(text.splitlines(), 1):
            if machine_paths(line):
                hits.append(f"{name}:{n}: {line.strip()[:120]}")
    assert not hits, "absolute paths of a development machine in committed files (use a path relative to the repo):\n" + "\n".join(hits)
