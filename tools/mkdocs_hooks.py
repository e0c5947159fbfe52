"""mkdocs hooks: the docs pages link to the committed results and scenarios beside docs/ (so that the links also
work when the Markdown is read in the repository); the site takes those files in at the same relative place, and
the README is its home page.

The files of `SHIPPED` (repository-relative directories, run directories left out) join the site as if they lay
in docs/, and a page's `../<dir>/` links are read as `<dir>/`; the README's and the CHANGELOG's `docs/` links
are read from docs/.
"""

from __future__ import annotations

from pathlib import Path

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ("results", "scenarios", "studies")
LEFT_OUT = "runs"  # study and paper run directories: large, not committed
FROM_ROOT = {"index.md": "README.md", "CHANGELOG.md": "CHANGELOG.md"}  # site page: the repository's file


def on_files(files: Files, config) -> Files:
    for name, source in FROM_ROOT.items():
        files.append(File.generated(config, name, abs_src_path=str(ROOT / source)))
    for top in SHIPPED:
        for path in sorted((ROOT / top).rglob("*")):
            relative = path.relative_to(ROOT)
            if path.is_file() and LEFT_OUT not in relative.parts:
                files.append(File(relative.as_posix(), str(ROOT), config["site_dir"], config["use_directory_urls"]))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    if page.file.src_uri in FROM_ROOT:
        return markdown.replace("](docs/", "](")
    for top in SHIPPED:
        markdown = markdown.replace(f"](../{top}/", f"]({top}/")
    return markdown
