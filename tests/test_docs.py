"""The documentation's code runs.

* Every Python block of the README, the changelog and the site (hand-written pages, the
  results notes and the generated model cards) is executed, page by page in one namespace, in
  the order written.  A block whose first line is ``# not run...`` (training, minutes of work) is
  only compiled; the marker is visible on the page.
* Every shell block's commands are checked without running them: each option of
  ``python scripts/<name>.py``, ``python -m rl_zoo3.<name>`` and ``make X`` must exist, and each
  repository path they read must exist.
* The README's headline table is the one the benchmark data gives
  (``python docs/_scripts/gen_results.py --readme-table``).
* Every registered id has its frame and GIF (``scripts/docs_media.py``), and that script checks
  its arguments before any work; the shipped GIFs play at their frame rate.
* The built site shows no unrendered markup: no literal backticks and no ``{role}`` text
  outside code blocks (a code span broken across a line that starts with ``- `` does that).

The Sphinx build itself (warnings as errors) is ``make docs``, which ``make test`` runs.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import re
import shlex
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest
from markdown_it import MarkdownIt

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SCRIPTS_DIR = DOCS / "_scripts"
if str(SCRIPTS_DIR) not in sys.path:
    sys.path.insert(0, str(SCRIPTS_DIR))

NOT_RUN = "# not run"
PYTHON_LANGS = {"python", "py", "python3"}
SHELL_LANGS = {"bash", "sh", "shell", "console"}
#: Options whose value is a file or folder the command writes (need not exist yet).
OUTPUT_OPTIONS = {"--out", "-o", "--run-dir", "--output"}
#: Repository folders whose paths in commands must exist.
REPO_PATH = re.compile(r"^(agents|docs|scripts|tests|planar3p_gym|planar3p_agents)/[\w./-]+$")


def _hand_written_pages() -> list[Path]:
    generated = {"_build", "_generated", "api", "envs", "models", "results", "benchmark"}
    pages = [ROOT / "README.md", ROOT / "CHANGELOG.md"]
    for path in sorted(DOCS.rglob("*.md")):
        rel = path.relative_to(DOCS)
        if rel.parts[0] not in generated:
            pages.append(path)
    return pages


PAGES = _hand_written_pages()


@functools.cache
def model_cards() -> tuple[Path, ...]:
    """The generated model cards (written by the generator, as the Sphinx build does)."""
    import gen_models

    gen_models.generate()
    return tuple(sorted((DOCS / "models").glob("*.md")))


def fences(path: Path) -> list[tuple[str, str, int]]:
    """``(language, code, first line number)`` of every fenced block of a Markdown file."""
    md = MarkdownIt("commonmark")
    out = []
    for tok in md.parse(path.read_text(encoding="utf-8")):
        if tok.type == "fence":
            lang = tok.info.strip().split()[0] if tok.info.strip() else ""
            out.append((lang, tok.content, tok.map[0] + 2 if tok.map else 0))
    return out


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def run_python_blocks(path: Path) -> int:
    """Execute the runnable Python blocks of ``path`` in one namespace; returns how many ran."""
    namespace: dict = {"__name__": f"docs_{path.stem}"}
    ran = 0
    for lang, code, line in fences(path):
        if lang not in PYTHON_LANGS:
            continue
        compiled = compile("\n" * (line - 1) + code, _rel(path), "exec")
        if code.lstrip().startswith(NOT_RUN):
            continue
        exec(compiled, namespace)
        ran += 1
    return ran


@pytest.mark.parametrize("path", PAGES, ids=_rel)
def test_python_blocks_run(path, capsys):
    """Each block runs, and none prints ``None`` as the label of other values (``None 0.25``:
    ``info["termination_reason"]`` printed at a time limit looks broken)."""
    run_python_blocks(path)
    printed = capsys.readouterr().out.splitlines()
    assert not [line for line in printed if line.startswith("None ")], printed


def test_model_card_blocks_run():
    cards = model_cards()
    assert cards, "no model cards were generated"
    for card in cards:
        run_python_blocks(card)


def test_every_page_with_code_marks_or_runs_it():
    """Python blocks that do not run say so on their first line; the site has runnable ones."""
    runnable = 0
    for path in PAGES:
        for lang, code, _ in fences(path):
            if lang in PYTHON_LANGS and not code.lstrip().startswith(NOT_RUN):
                runnable += 1
    assert runnable >= 15


# --- shell commands -----------------------------------------------------------------------


@functools.cache
def _help_flags(argv: tuple[str, ...]) -> frozenset[str]:
    out = subprocess.run(
        [sys.executable, *argv, "--help"], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    return frozenset(re.findall(r"(?<![\w-])(--?[A-Za-z][\w-]*)", out.stdout + out.stderr))


@functools.cache
def _source_flags(source: Path) -> frozenset[str]:
    return frozenset(re.findall(r"[\"'](--?[A-Za-z][\w-]*)[\"']", source.read_text()))


def _flags_ok(flags: set[str], source: Path, argv: tuple[str, ...]) -> set[str]:
    """The options of ``flags`` that ``source`` does not define (by its text, else by its
    ``--help``)."""
    missing = {f for f in flags if f not in _source_flags(source)}
    if missing:
        missing -= _help_flags(argv)
    return missing


@functools.cache
def _make_targets() -> frozenset[str]:
    text = (ROOT / "Makefile").read_text()
    return frozenset(re.findall(r"(?m)^([A-Za-z][\w-]*)\s*:", text))


def _commands(code: str) -> list[list[str]]:
    """The commands of a shell block: continuation lines joined, comments removed."""
    joined = re.sub(r"\\\n", " ", code)
    out = []
    for line in joined.splitlines():
        try:
            words = shlex.split(line, comments=True)
        except ValueError:
            continue
        if words:
            out.append(words)
    return out


_NUMBER = re.compile(r"^-?\d+(\.\d+)?(e-?\d+)?$")


def check_command(words: list[str]) -> list[str]:
    """Problems of one command line (empty when it is fine)."""
    problems = []
    if words[0] == "make":
        for target in words[1:]:
            if not target.startswith("-") and "=" not in target and target not in _make_targets():
                problems.append(f"make target {target!r} is not in the Makefile")
        return problems
    if words[0] not in ("python", "python3"):
        return problems
    rest = words[1:]
    source = argv = None
    if rest and rest[0].startswith("scripts/"):
        source = ROOT / rest[0]
        if not source.exists():
            return [f"{rest[0]} does not exist"]
        argv, args = (rest[0],), rest[1:]
    elif len(rest) >= 2 and rest[0] == "-m":
        spec = importlib.util.find_spec(rest[1]) if rest[1].startswith("rl_zoo3") else None
        if spec is None or spec.origin is None:
            return problems
        source, argv, args = Path(spec.origin), ("-m", rest[1]), rest[2:]
    elif len(rest) >= 2 and rest[0] == "-c":
        m = re.search(r"run_module\(['\"]([\w.]+)['\"]", rest[1])
        if not m:
            return problems
        spec = importlib.util.find_spec(m.group(1))
        assert spec is not None and spec.origin is not None, m.group(1)
        source, argv, args = Path(spec.origin), ("-m", m.group(1)), rest[2:]
    else:
        return problems
    flags = {a.split("=", 1)[0] for a in args if a.startswith("-") and not _NUMBER.match(a)}
    missing = _flags_ok(flags, source, argv)
    problems += [f"{' '.join(argv)} has no option {f}" for f in sorted(missing)]
    for prev, word in zip(["", *args], args, strict=False):
        if prev in OUTPUT_OPTIONS:
            continue
        for part in word.split(","):
            part = part.split(":stats=")[0]
            if REPO_PATH.match(part) and not any(c in part for c in "*?{}") and "..." not in part:
                if not (ROOT / part).exists():
                    problems.append(f"{part} does not exist")
    return problems


def shell_pages() -> list[Path]:
    return [*PAGES, *sorted((DOCS / "_notes").rglob("*.md"))]


@pytest.mark.parametrize("path", sorted(set(shell_pages())), ids=_rel)
def test_shell_commands_exist(path):
    problems = []
    for lang, code, line in fences(path):
        if lang not in SHELL_LANGS:
            continue
        for words in _commands(code):
            problems += [f"{_rel(path)}:{line}: {p}" for p in check_command(words)]
    assert not problems, "\n".join(problems)


def test_model_card_commands_exist():
    problems = []
    for card in model_cards():
        for lang, code, line in fences(card):
            if lang in SHELL_LANGS:
                for words in _commands(code):
                    problems += [f"{card.name}:{line}: {p}" for p in check_command(words)]
    assert not problems, "\n".join(problems)


def test_training_snippets_use_one_torch_thread():
    """Every training command and snippet sets one torch thread (6-19x slower otherwise)."""
    problems = []
    for path in shell_pages():
        for lang, code, line in fences(path):
            if lang in PYTHON_LANGS and re.search(r"\.learn\(|HerReplayBuffer", code):
                if "torch.set_num_threads(1)" not in code:
                    problems.append(f"{_rel(path)}:{line}: no torch.set_num_threads(1)")
            if lang in SHELL_LANGS:
                for words in _commands(code):
                    text = " ".join(words)
                    if "rl_zoo3.train" in text and not (
                        "--num-threads 1" in text and "--conf-file" in text
                    ):
                        problems.append(
                            f"{_rel(path)}:{line}: rl_zoo3.train without "
                            "--num-threads 1 and --conf-file"
                        )
    assert not problems, "\n".join(problems)


# --- README ------------------------------------------------------------------------------


def test_readme_is_short_and_its_headline_table_is_the_data():
    import gen_results

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 220
    table = gen_results.headline_table(readme=True)
    assert table in text, (
        "the README's headline table differs from the benchmark data; paste the output of "
        "`python docs/_scripts/gen_results.py --readme-table`"
    )


def test_headline_figure_is_the_data_and_is_shown():
    """The headline figure's numbers (written beside it with the PNG by
    ``python docs/_scripts/gen_results.py --headline-figure``) are the benchmark data's, and
    the README and the results page show it."""
    import json

    import gen_results

    saved = json.loads(gen_results.HEADLINE_FIGURE_DATA.read_text())
    assert saved == gen_results.headline_scores(), (
        "the headline figure differs from the benchmark data; run "
        "`python docs/_scripts/gen_results.py --headline-figure`"
    )
    assert gen_results.HEADLINE_FIGURE.is_file()
    kinds = {e["kind"] for e in saved}
    assert kinds == {"learned", "strongest baseline", "paper's controller"}
    assert all(lo <= p <= hi for e in saved for p, lo, hi in [e["score"]])
    assert "(docs/figures/results_headline.png)" in (ROOT / "README.md").read_text()
    assert "(figures/results_headline.png)" in (DOCS / "results.md").read_text()


def test_the_demo_figures_are_generated_from_its_data():
    """The installation page quotes the demo's figures through the generated fragment only
    (they went stale when typed), and the demo data is a run of the demo as it is now: its
    parts' policies, suites, episodes and seed."""
    import json

    import gen_results

    from planar3p_agents.commands import benchmark, demo

    text = (DOCS / "installation.md").read_text()
    assert "_generated/demo_figures.md" in text
    assert not re.search(r"\d\.\d\dx|\d+ % (each|against)", text), "a typed demo figure"
    parts = {
        p.out.name: (p.policies, p.suites)
        for p in demo.parts(Path("demo"), demo.REACH_POLICY, demo.MODE_CHANGE_POLICY, 0)
    }
    assert set(parts) == {"reach", "mode-change"}
    for part, (policies, suites) in parts.items():
        settings = json.loads((gen_results.DEMO_DATA / f"{part}.json").read_text())["settings"]
        assert list(settings["policies"]) == policies and settings["suites"] == suites, part
        assert settings["episodes"] == benchmark.QUICK_EPISODES and settings["seed"] == 0
        assert settings["command"].startswith("planar3p demo")
    figures = gen_results.demo_figures()
    assert demo.REACH_POLICY in figures and "x the speed bound" in figures


def test_readme_lists_every_registered_id():
    import p3docs

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    missing = [i for i in p3docs.registered_ids() if f"`{i}`" not in text]
    assert not missing, f"ids missing from the README's table: {missing}"


# --- media --------------------------------------------------------------------------------


def test_every_registered_id_has_its_media():
    import p3docs

    media = DOCS / "_static" / "envs"
    missing = [
        f"{i}{ext}"
        for i in p3docs.registered_ids()
        for ext in (".png", ".gif", ".json")
        if not (media / f"{i}{ext}").exists()
    ]
    assert not missing, f"run `python scripts/docs_media.py`; missing: {missing}"
    too_big = [p.name for p in media.glob("*.gif") if p.stat().st_size > 400 * 1024]
    assert not too_big, f"GIFs above 400 kB: {too_big}"


def test_shipped_gifs_play_at_their_frame_rate():
    """Every shipped GIF shows each frame for a real time (a delay of 0 plays as fast as the
    browser can, or at its default) and holds its last picture at least a second."""
    from gif_helpers import gif_delays

    problems = []
    for path in sorted((DOCS / "_static" / "envs").glob("*.gif")):
        delays, loop = gif_delays(path)
        if min(delays) < 20 or delays[-1] < 1000 or loop != 0:
            problems.append(f"{path.name}: delays {delays[:3]}...{delays[-1:]} ms, loop {loop}")
    assert not problems, "run `python scripts/docs_media.py`:\n" + "\n".join(problems)


def _media(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "scripts/docs_media.py", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )


def test_docs_media_checks_its_arguments_first(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    r = _media("--out", str(blocker), "--ids", "Planar3P-v0")
    assert r.returncode == 2 and "--out" in r.stderr
    r = _media("--out", str(tmp_path / "m"), "--ids", "NoSuchId-v0")
    assert r.returncode == 2 and "--ids" in r.stderr
    r = _media("--out", str(tmp_path / "m"), "--size", "10x10")
    assert r.returncode == 2 and "--size" in r.stderr
    assert not (tmp_path / "m").exists()


def test_docs_media_writes_a_frame_a_gif_and_a_caption(tmp_path):
    out = tmp_path / "media"
    r = _media(
        "--out",
        str(out),
        "--ids",
        "Planar3P-v0",
        "--max-steps",
        "4",
        "--size",
        "96x72",
        "--frame-size",
        "96x72",
    )
    assert r.returncode == 0, r.stderr
    assert {p.name for p in out.iterdir()} == {
        "Planar3P-v0.png",
        "Planar3P-v0.gif",
        "Planar3P-v0.json",
    }


def test_repository_paths_named_in_the_pages_exist():
    """Paths written in inline code (`agents/training/hyperparams/ppo.yml`) must exist, so that a
    moved file shows up here rather than as a dead reference on the site."""
    problems = []
    for path in shell_pages():
        text = path.read_text(encoding="utf-8")
        for m in re.finditer(r"`([^`\s]+)`", text):
            token = m.group(1).rstrip(".,;:)")
            if not REPO_PATH.match(token) or any(c in token for c in "<>*?{}") or "..." in token:
                continue
            if not (ROOT / token).exists():
                line = text.count("\n", 0, m.start()) + 1
                problems.append(f"{_rel(path)}:{line}: {token} does not exist")
    assert not problems, "\n".join(problems)


# --- the built site -----------------------------------------------------------------------

#: Where the site's text comes from: a build older than any of these is rebuilt.
SITE_SOURCES = ("docs", "planar3p_gym", "agents", "README.md", "CHANGELOG.md")
#: A MyST role left as text, ``{mod}`planar3p_gym...```.
RAW_ROLE = re.compile(r"\{[a-z]+(?::[a-z]+)*\}`")


def _newest_source() -> float:
    newest = 0.0
    for name in SITE_SOURCES:
        path = ROOT / name
        files = [path] if path.is_file() else path.rglob("*")
        for f in files:
            if "_build" not in f.parts and f.suffix in (".md", ".py", ".json", ".csv", ".yml"):
                newest = max(newest, f.stat().st_mtime)
    return newest


@pytest.fixture(scope="module")
def built_site(tmp_path_factory) -> Path:
    """The HTML site: ``make docs``'s (``make test`` builds it first) when it is newer than
    every source, else a build of its own (the same command, about a minute)."""
    html = DOCS / "_build" / "html"
    index = html / "index.html"
    if index.exists() and index.stat().st_mtime >= _newest_source():
        return html
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "MPLBACKEND": "Agg"}
    cmd = [sys.executable, "-m", "sphinx", "-q", "-b", "html", "-d", str(out / "doctrees")]
    r = subprocess.run(
        [*cmd, str(DOCS), str(out / "html")], capture_output=True, text=True, env=env, cwd=ROOT
    )
    assert r.returncode == 0, r.stderr[-3000:]
    return out / "html"


class _Text(HTMLParser):
    """A page's text outside code blocks: ``prose`` (outside any code) and ``code`` (inline
    code spans)."""

    BLOCKS = frozenset({"pre", "script", "style", "textarea"})

    def __init__(self) -> None:
        super().__init__()
        self.block = self.inline = 0
        self.prose: list[str] = []
        self.code: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.block += tag in self.BLOCKS
        self.inline += tag == "code"

    def handle_endtag(self, tag):
        self.block -= tag in self.BLOCKS
        self.inline -= tag == "code"

    def handle_data(self, data):
        if not self.block:
            (self.code if self.inline else self.prose).append(data)


def unrendered_markup(html: str) -> list[str]:
    """Markup a page shows as text: backticks in its prose (a code span that did not parse)
    and roles anywhere outside code blocks (``{mod}`x``` as text)."""
    parser = _Text()
    parser.feed(html)
    prose, code = "".join(parser.prose), "".join(parser.code)
    found = [prose[max(0, m.start() - 40) : m.end() + 40] for m in re.finditer("`+", prose)]
    found += [
        t[max(0, m.start() - 30) : m.end() + 30]
        for t in (prose, code)
        for m in RAW_ROLE.finditer(t)
    ]
    return [" ".join(f.split()) for f in found]


def test_unrendered_markup_is_found():
    """The check finds what a broken code span leaves (literal double backticks, a raw role
    inside a code span) and lets code blocks and rendered code through."""
    broken = (
        "<p>``-w_pose * e - w_singularity * barrier</p><ul><li><p>w_action<code>"
        "<span>({mod}`planar3p_gym.tasks.rewards`):</span></code></p></li></ul>"
    )
    assert len(unrendered_markup(broken)) == 2
    fine = "<p>The <code>`x`</code> role</p><pre>echo `date` {mod}`x`</pre>"
    assert unrendered_markup(fine) == []


def test_built_pages_show_no_unrendered_markup(built_site):
    problems = []
    for page in sorted(built_site.rglob("*.html")):
        rel = page.relative_to(built_site)
        if rel.parts[0] in ("_sources", "_static", "_images"):
            continue
        problems += [f"{rel}: {t!r}" for t in unrendered_markup(page.read_text(encoding="utf-8"))]
    assert not problems, "\n".join(problems)


def test_probing_a_reference_prints_nothing_of_the_import():
    """The build probes references by importing them; gymnasium.utils.play (named by the
    keyboard mapping's docstring) warned "matplotlib is not installed" once pyplot ran
    headless, though matplotlib is installed."""
    code = (
        "import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot\n"
        "import p3docs\n"
        "assert p3docs._import_dotted('gymnasium.utils.play.play') is not None\n"
    )
    path = [str(SCRIPTS_DIR), str(ROOT), os.environ.get("PYTHONPATH", "")]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(path)}
    r = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert r.returncode == 0, r.stderr
    assert "not installed" not in r.stderr, r.stderr
