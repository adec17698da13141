"""Repository hygiene: no committed file names an absolute path of a
development machine (issue 17: a `source:` line once carried one)."""
import re
import subprocess

# Home and work directories of the machines this project is developed and
# tested on, and of the usual desktop systems. /tmp is not listed: the docs
# use it for example output folders, which are not machine-specific.
MACHINE_PATH = re.compile(r"(?<![\w.~-])/(?:work|root|home|Users)/[\w.-]")


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
    assert MACHINE_PATH.search("source: 'naic explain on /work/shared/data/x.csv'")
    assert MACHINE_PATH.search("cd /root/.cargo")
    assert MACHINE_PATH.search("/home/alice/robot.urdf")
    assert not MACHINE_PATH.search("../shared/data/jk5-friction/x.csv")
    assert not MACHINE_PATH.search("--out /tmp/run")
    assert not MACHINE_PATH.search("crates/naic_core/src/work/x.rs")


def test_no_committed_file_names_an_absolute_machine_path(root):
    files = list(tracked_text_files(root))
    assert len(files) > 100, f"git ls-files listed only {len(files)} text files: is this a git checkout?"
    hits = []
    for name, text in files:
        if name == "tests/python/test_repo_hygiene.py":
            continue  # the patterns above are examples, not paths
        for n, line in enumerate(text.splitlines(), 1):
            if MACHINE_PATH.search(line):
                hits.append(f"{name}:{n}: {line.strip()[:120]}")
    assert not hits, "absolute paths of a development machine in committed files (use a path relative to the repo):\n" + "\n".join(hits)
