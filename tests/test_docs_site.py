"""The documentation site builds with `mkdocs build --strict` (broken links, unknown API references and
unrendered docstrings fail) and has the pages it promises: the hook reference, the API reference and
one page per plugin, pulled from the plugins' READMEs at build time (docs/_hooks.py)."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.skipif(
    any(importlib.util.find_spec(m) is None for m in ("mkdocs", "material", "mkdocstrings_handlers.python")),
    reason="mkdocs, mkdocs-material or mkdocstrings-python is not installed (the dev environment has them)",
)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONDONTWRITEBYTECODE": "1", "NO_COLOR": "1"}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=900,  # minutes on a loaded 2-core machine
    )
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{log[-6000:]}"
    return out, log


def _text(page: Path) -> str:
    assert page.is_file(), f"{page} was not built"
    return page.read_text(encoding="utf-8")


@pytest.mark.slow
def test_build_prints_no_warning(site: tuple[Path, str]) -> None:
    _, log = site
    problems = [line for line in log.splitlines() if re.search(r"\b(WARNING|ERROR)\b", line)]
    assert not problems, "\n".join(problems)


@pytest.mark.slow
def test_hook_reference_has_every_hook(site: tuple[Path, str]) -> None:
    out, _ = site
    html = _text(out / "hooks" / "index.html")
    hookspecs = (ROOT / "rio-core" / "src" / "rio" / "plugins" / "hookspecs.py").read_text(encoding="utf-8")
    hooks = re.findall(r"^def (rio_\w+)\(", hookspecs, re.M)
    assert "rio_drivers" in hooks
    for hook in hooks:  # a section with the generated signature for each hook
        assert f'id="rio.plugins.hookspecs.{hook}"' in html, f"hooks page lacks a section for {hook}"
    text = re.sub(r"<[^>]+>", "", html)
    assert "rio_drivers() -&gt; list[Spec]" in text or "rio_drivers() -> list[Spec]" in text


@pytest.mark.slow
def test_api_reference_renders_docstrings(site: tuple[Path, str]) -> None:
    out, _ = site
    top = _text(out / "api" / "rio" / "index.html")
    assert 'id="rio.Node"' in top  # class Node, with its docstrings
    assert "Fields every node accepts." in top  # Node.Config's docstring
    node = _text(out / "api" / "node" / "index.html")
    assert "runnable over any middleware" in node  # rio.runtime.node's module docstring: the Node contract
    interfaces = _text(out / "api" / "interfaces" / "index.html")
    assert 'id="rio.interfaces.ArmNode"' in interfaces


@pytest.mark.slow
def test_the_command_reference_is_made_from_the_command(site: tuple[Path, str]) -> None:
    out, _ = site
    text = re.sub(r"<[^>]+>", "", _text(out / "cli-reference" / "index.html"))
    for command in ("rio teleop", "rio deploy", "rio replay", "rio run", "rio stations copy", "rio export"):
        assert command in text, f"the command reference lacks {command}"
    assert "--ready-timeout" in text and "Seconds the station's nodes may take to start" in text


@pytest.mark.slow
def test_plugin_pages_come_from_readmes(site: tuple[Path, str]) -> None:
    out, _ = site
    readme = (ROOT / "plugins" / "rio-so100" / "README.md").read_text(encoding="utf-8")
    html = _text(out / "plugins" / "rio-so100" / "index.html")
    title = next((line[2:].strip() for line in readme.splitlines() if line.startswith("# ")), "rio-so100")
    assert title.strip("`") in html
    assert "so100.follower" in html
    for folder in sorted((ROOT / "plugins").iterdir()):  # every plugin with a README has its page
        if (folder / "README.md").is_file():
            assert (out / "plugins" / folder.name / "index.html").is_file(), folder.name
    nav = _text(out / "index.html")
    assert 'href="plugins/rio-so100/"' in nav


def test_links_leaving_the_site_point_at_the_repository() -> None:
    spec = importlib.util.spec_from_file_location("rio_docs_hooks", ROOT / "docs" / "_hooks.py")
    assert spec is not None and spec.loader is not None
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    pages = {"docs/stations.md": "stations.md", "plugins/rio-so100/README.md": "plugins/rio-so100.md",
             "plugins/rio-ufactory/README.md": "plugins/rio-ufactory.md"}
    md = ("[a](../../docs/stations.md#roles) [b](src/rio_so100/plugin.py) [c](../rio-ufactory/README.md) "
          "[d](tests/) `[e](src/x.py)`\n```\n[f](../../README.md)\n```\n")
    got = hooks.rewrite_links(md, "plugins/rio-so100/README.md", "plugins/rio-so100.md", pages)
    blob = "https://github.com/rio-robotics/rio/blob/main/plugins/rio-so100/src/rio_so100/plugin.py"
    assert "[a](../stations.md#roles)" in got
    assert f"[b]({blob})" in got
    assert "[c](rio-ufactory.md)" in got
    assert "[d](https://github.com/rio-robotics/rio/tree/main/plugins/rio-so100/tests)" in got
    assert "`[e](src/x.py)`" in got and "[f](../../README.md)" in got  # code is left alone
