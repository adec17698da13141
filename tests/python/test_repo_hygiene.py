"""Repository hygiene: no committed file names an absolute path of a
development machine (issue 17: a `source:` line once carried one), and no
library, node or CLI source returns `Result<_, String>` (issue 17: one error
style, thiserror types that name the field, the value and the rule); and the suite's
own leftover-process check kills only what the suite started."""
import os
import pathlib
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


# --- Result<_, String> in non-test Rust source ----------------------------------------------

RUST_SOURCE_ROOTS = ("crates/", "nodes/", "cli/")
# Third-party code kept as upstream wrote it, apart from a documented patch
# (crates/vendor/rustdds/PATCHED.md): not held to this project's style rules.
VENDORED_ROOTS = ("crates/vendor/",)
# String and char literals and comments, blanked before looking at types (a message may say
# "Result<(), String>"). Lifetimes ('a) are not char literals: a char literal closes at once.
RUST_NOISE = re.compile(
    r'//[^\n]*|/\*.*?\*/|b?r(#*)".*?"\1|b?"(?:\\.|[^"\\])*"|b?\'(?:\\.|[^\'\\])\'',
    re.S,
)


def blank(text):
    """`text` with comments and literals replaced by spaces (line numbers kept)."""
    return RUST_NOISE.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def without_cfg_test(code):
    """`code` (already blanked) with every `#[cfg(test)]` item (a `mod tests { .. }`, a test
    helper) replaced by spaces, newlines kept."""
    out = list(code)
    for m in re.finditer(r"#\s*\[\s*cfg\s*\(\s*test\s*\)\s*\]", code):
        i, depth = m.end(), 0
        while i < len(code):  # the item ends at its `;` or at the `}` closing its first `{`
            c = code[i]
            if c == "{":
                depth += 1
            elif c == "}":
                depth -= 1
                if depth == 0:
                    break
            elif c == ";" and depth == 0:
                break
            i += 1
        for k in range(m.start(), min(i + 1, len(code))):
            if out[k] != "\n":
                out[k] = " "
    return "".join(out)


def string_error_results(code):
    """(line, text) of each `Result<…, String>` type in `code` (blanked): a `Result` whose
    last generic argument, at the top level of its brackets, is `String`."""
    hits = []
    for m in re.finditer(r"\bResult\s*<", code):
        depth, i, args, start = 1, m.end(), [], m.end()
        while i < len(code) and depth:
            c = code[i]
            if c == "<":
                depth += 1
            elif c == ">" and code[i - 1] != "-":  # `->` of an `Fn() -> T` is no bracket
                depth -= 1
            elif c in "([":
                depth += 1
            elif c in ")]":
                depth -= 1
            elif c == "," and depth == 1:
                args.append(code[start:i])
                start = i + 1
            i += 1
        args.append(code[start:i - 1])
        args = [a for a in args if a.strip()]  # a trailing comma leaves an empty last argument
        if len(args) >= 2 and re.sub(r"\s+", "", args[-1]) in ("String", "std::string::String", "alloc::string::String"):
            hits.append((code.count("\n", 0, m.start()) + 1, re.sub(r"\s+", " ", code[m.start():i])))
    return hits


def is_test_file(name):
    """Integration tests, benches and their helpers (`crates/x/tests/common/mod.rs`)."""
    return any(part in ("tests", "benches") for part in name.split("/")[:-1])


def test_the_result_string_scan_catches_string_errors_and_spares_typed_ones():
    def scan(text):
        return [t for _, t in string_error_results(without_cfg_test(blank(text)))]

    assert scan("pub fn parse(s: &str) -> Result<Self, String> {") == ["Result<Self, String>"]
    assert scan("fn f() -> Option<Result<Vec<(u8, f64)>, String>> {") == ["Result<Vec<(u8, f64)>, String>"]
    assert scan("fn f() -> Result<\n    HashMap<String, u8>,\n    std::string::String,\n> {")
    assert scan("let t = spawn(move || -> Result<serde_json::Value, String> {")
    assert scan("type R = Result<Box<dyn Fn(u8) -> u8>, String>;")
    assert not scan("fn f() -> Result<String, ParamError> {")
    assert not scan("fn f() -> Result<HashMap<String, String>, ParamError> {")
    assert not scan("fn f() -> io::Result<String> {")
    assert not scan('let m = "returns Result<(), String>"; // Result<u8, String>')
    assert not scan("/* Result<u8, String> */ fn g<'a>(x: &'a str) -> Result<&'a str, E> {")
    assert not scan("#[cfg(test)]\nmod tests {\n    fn check() -> Result<(), String> { Ok(()) }\n}\n")
    assert scan("#[cfg(test)]\nmod tests {\n    fn check() {}\n}\nfn after() -> Result<(), String> {}\n") == ["Result<(), String>"]
    assert not scan("#[cfg(test)]\nfn helper() -> Result<(), String> { Ok(()) }")
    assert is_test_file("crates/naic_explain/tests/hidden_effects.rs")
    assert is_test_file("crates/naic_sim/tests/common/mod.rs")
    assert not is_test_file("crates/naic_core/examples/dump_dynamics.rs")
    assert not is_test_file("cli/src/cmd/launch.rs")


def test_no_library_node_or_cli_source_returns_a_string_error(root):
    files = [(n, t) for n, t in tracked_text_files(root)
             if n.endswith(".rs") and n.startswith(RUST_SOURCE_ROOTS) and not n.startswith(VENDORED_ROOTS)]
    scanned = [(n, t) for n, t in files if not is_test_file(n)]
    assert len(scanned) > 100, f"only {len(scanned)} non-test Rust files under {RUST_SOURCE_ROOTS}: is this a git checkout?"
    hits = [
        f"{name}:{line}: {text}"
        for name, text in scanned
        for line, text in string_error_results(without_cfg_test(blank(text)))
    ]
    assert not hits, (
        "Result<_, String> in library, node or CLI code: return a thiserror type whose variants name the field, "
        "the value and the rule (e.g. naic_ros::params_file::ParamsFileError):\n" + "\n".join(hits)
    )


def test_the_leftover_check_counts_only_processes_this_run_started():
    """conftest's check after each test file kills what a test left running; a process the
    user (or another checkout) started beside the suite, without this run's mark in its
    environment, is not one of them."""
    import conftest
    ours = subprocess.Popen(["sleep", "30"], env=dict(os.environ))
    theirs = subprocess.Popen(["sleep", "30"], env={k: v for k, v in os.environ.items() if k != "NAIC_TEST_RUN"})
    try:
        assert conftest._started_here(pathlib.Path(f"/proc/{ours.pid}")), "a process started by the suite lacks its mark"
        assert not conftest._started_here(pathlib.Path(f"/proc/{theirs.pid}")), "a process without the mark counts as the suite's"
    finally:
        for p in (ours, theirs):
            p.kill()
            p.wait()
