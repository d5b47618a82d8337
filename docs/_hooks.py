"""MkDocs hooks for the RIO documentation site (registered in mkdocs.yml under `hooks:`).

- Plugin pages: each `plugins/<name>/README.md` becomes the page `plugins/<name>.md` and each
  `plugins/<name>/docs/X.md` the page `plugins/<name>/X.md`, generated at build time (nothing is
  copied into the repository), with an overview table (`plugins/overview.md`), and the nav's
  "Plugins" section lists them (it replaces the placeholder entry `plugins/_generated` in
  mkdocs.yml). No page is named index.md there: material's navigation.indexes would take it for the
  section's index.
- Links: a relative link on any page that points outside the site's pages (a source file, a folder,
  the root README, a plugin's tests) is rewritten to the file on GitHub, and a link to a repository
  file that the site has as a page (a plugin README, a docs/*.md page) to that page, so README text
  written for GitHub builds under `mkdocs build --strict`. Code blocks and inline code are left alone.
- Edit links point at the real file in the repository (a plugin README for its page).
- The command reference (`cli-reference.md`) is made from the `rio` command itself (`rio.cli.reference`).
"""

from __future__ import annotations

import importlib
import posixpath
import re
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

REPO_URL = "https://github.com/rio-robotics/rio"
BRANCH = "main"
ROOT = Path(__file__).resolve().parent.parent
PLACEHOLDER = "plugins/_generated"
OVERVIEW = "plugins/overview.md"  # generated: the table of plugins (not index.md: docs/plugins.md owns plugins/)
CLI_REFERENCE = "cli-reference.md"  # generated from the rio command itself (rio.cli.reference)

# site page (src_uri) -> repository path, for generated pages
_GENERATED: dict[str, str] = {}


def _plugin_sources() -> list[tuple[str, str, str]]:
    """(plugin folder name, repository path, site src_uri) of every plugin page, README first."""
    out: list[tuple[str, str, str]] = []
    for folder in sorted((ROOT / "plugins").iterdir()):
        readme = folder / "README.md"
        if not folder.is_dir() or not readme.is_file():
            continue
        out.append((folder.name, f"plugins/{folder.name}/README.md", f"plugins/{folder.name}.md"))
        docs = folder / "docs"
        if docs.is_dir():
            for md in sorted(docs.glob("*.md")):
                out.append((folder.name, f"plugins/{folder.name}/docs/{md.name}", f"plugins/{folder.name}/{md.name}"))
    return out


def on_config(config: Any) -> Any:
    """Fill the nav's plugin placeholder with one entry (or section) per plugin."""
    sources = _plugin_sources()
    entries: list[Any] = [{"Overview": OVERVIEW}]
    for name in dict.fromkeys(s[0] for s in sources):
        pages = [s for s in sources if s[0] == name]
        if len(pages) == 1:
            entries.append({name: pages[0][2]})
        else:
            entries.append({name: [{"Overview": pages[0][2]}, *({Path(p[1]).stem: p[2]} for p in pages[1:])]})

    def fill(items: Any) -> Any:
        if isinstance(items, list):
            result: list[Any] = []
            for item in items:
                if item == PLACEHOLDER:
                    result.extend(entries)
                elif isinstance(item, dict) and list(item.values()) == [PLACEHOLDER]:
                    result.extend(entries)
                else:
                    result.append(fill(item))
            return result
        if isinstance(items, dict):
            return {key: fill(value) for key, value in items.items()}
        return items

    if config.get("nav"):
        config["nav"] = fill(config["nav"])
    return config


def _description(folder: str) -> str:
    """The plugin's one-line description: its pyproject's, else the README's first paragraph line."""
    try:
        tomllib = importlib.import_module("tomllib")  # Python 3.11+; on 3.10 the README's line is used
        with open(ROOT / "plugins" / folder / "pyproject.toml", "rb") as f:
            description = tomllib.load(f).get("project", {}).get("description", "")
        if description:
            return str(description)
    except (ImportError, OSError, ValueError):  # tomllib.TOMLDecodeError is a ValueError
        pass
    for line in (ROOT / "plugins" / folder / "README.md").read_text(encoding="utf-8").splitlines():
        if line.strip() and not line.startswith(("#", "<", "[", "!", "```", "|")):
            return line.strip()
    return ""


def _overview() -> str:
    rows = [f"| [{name}]({name}.md) | {_description(name).replace('|', '/')} |"
            for name in dict.fromkeys(s[0] for s in _plugin_sources())]
    return "\n".join([
        "# Plugins in this repository", "",
        "Each is its own distribution under `plugins/`, found through the `rio` entry-point group; "
        "`uv sync --all-extras` installs them. Writing your own: [Writing a plugin](../plugins.md) and "
        "[Plugin hooks](../hooks.md).", "",
        "| plugin | what it provides |", "|---|---|", *rows, ""])


def on_files(files: Files, config: Any) -> Files:
    _GENERATED.clear()
    if files.get_file_from_path(OVERVIEW) is None:
        overview = File.generated(config, OVERVIEW, content=_overview())
        overview.edit_uri = None
        files.append(overview)
        _GENERATED[OVERVIEW] = "docs/" + OVERVIEW  # a page of docs/ as far as links go
    if files.get_file_from_path(CLI_REFERENCE) is None:
        from rio.cli.reference import reference

        page = File.generated(config, CLI_REFERENCE, content=reference())
        page.edit_uri = None
        files.append(page)
        _GENERATED[CLI_REFERENCE] = "docs/" + CLI_REFERENCE
    for _name, repo_path, src_uri in _plugin_sources():
        if files.get_file_from_path(src_uri) is not None:
            continue
        content = (ROOT / repo_path).read_text(encoding="utf-8")
        generated = File.generated(config, src_uri, content=content)
        generated.edit_uri = repo_path
        files.append(generated)
        _GENERATED[src_uri] = repo_path
    for file in files:
        if file.is_documentation_page() and file.src_uri not in _GENERATED:
            file.edit_uri = f"docs/{file.src_uri}"
    return files


_FENCE = re.compile(r"^\s{0,3}(`{3,}|~{3,})")
_INLINE_CODE = re.compile(r"(`+)(?:.|\n)*?(?<!`)\1(?!`)")
_INLINE_LINK = re.compile(r"(\]\()(<[^>]*>|[^)\s]+)((?:\s+\"[^\"]*\")?\))")
_REF_DEF = re.compile(r"^(\s{0,3}\[[^\]]+\]:\s*)(\S+)(.*)$", re.M)
_HTML_ATTR = re.compile(r"""((?:href|src)=)(["'])([^"']+)\2""")


def _rewrite(target: str, page_repo_path: str, page_src_uri: str, site_pages: dict[str, str]) -> str:
    """The link `target` found in the file `page_repo_path`, as the site should have it."""
    bare = target[1:-1] if target.startswith("<") and target.endswith(">") else target
    if not bare or bare.startswith(("#", "/", "mailto:")) or re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", bare):
        return target
    path, sep, anchor = bare.partition("#")
    repo_target = posixpath.normpath(posixpath.join(posixpath.dirname(page_repo_path), path))
    if repo_target.startswith(".."):
        return target  # outside the repository: leave it for mkdocs to report
    if repo_target in site_pages:  # a page of the site: link to it
        rel = posixpath.relpath(site_pages[repo_target], posixpath.dirname(page_src_uri) or ".")
        return rel + sep + anchor
    if not (ROOT / repo_target).exists():
        return target  # a broken link: leave it for mkdocs to report
    if repo_target.startswith("docs/"):
        rel = posixpath.relpath(repo_target[len("docs/"):], posixpath.dirname(page_src_uri) or ".")
        return rel + sep + anchor  # a static file of docs/ (an image): mkdocs copies it
    kind = "tree" if (ROOT / repo_target).is_dir() or repo_target == "." else "blob"
    suffix = "" if repo_target == "." else "/" + repo_target
    return f"{REPO_URL}/{kind}/{BRANCH}{suffix}" + sep + anchor


def _rewrite_text(text: str, fn: Any) -> str:
    """Apply `fn` to link targets outside code spans of one prose chunk."""
    pieces: list[str] = []
    last = 0
    for m in _INLINE_CODE.finditer(text):
        pieces.append(_rewrite_prose(text[last:m.start()], fn))
        pieces.append(m.group(0))
        last = m.end()
    pieces.append(_rewrite_prose(text[last:], fn))
    return "".join(pieces)


def _rewrite_prose(text: str, fn: Any) -> str:
    text = _INLINE_LINK.sub(lambda m: m.group(1) + fn(m.group(2)) + m.group(3), text)
    text = _REF_DEF.sub(lambda m: m.group(1) + fn(m.group(2)) + m.group(3), text)
    return _HTML_ATTR.sub(lambda m: m.group(1) + m.group(2) + fn(m.group(3)) + m.group(2), text)


def rewrite_links(markdown: str, page_repo_path: str, page_src_uri: str, site_pages: dict[str, str]) -> str:
    def fn(target: str) -> str:
        return _rewrite(target, page_repo_path, page_src_uri, site_pages)

    out: list[str] = []
    prose: list[str] = []
    fence: str | None = None
    for line in markdown.splitlines(keepends=True):
        m = _FENCE.match(line)
        if fence is None:
            if m:
                out.append(_rewrite_text("".join(prose), fn))
                prose = []
                fence = m.group(1)
                out.append(line)
            else:
                prose.append(line)
        else:
            out.append(line)
            closing = m.group(1) if m else ""
            if closing[:1] == fence[0] and len(closing) >= len(fence) and not line.strip()[len(closing):].strip():
                fence = None
    if prose:
        out.append(_rewrite_text("".join(prose), fn))
    return "".join(out)


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    src_uri = page.file.src_uri
    repo_path = _GENERATED.get(src_uri, f"docs/{src_uri}")
    site_pages = {f"docs/{f.src_uri}": f.src_uri for f in files
                  if f.is_documentation_page() and f.src_uri not in _GENERATED}
    site_pages.update({repo: uri for uri, repo in _GENERATED.items()})
    return rewrite_links(markdown, repo_path, src_uri, site_pages)
