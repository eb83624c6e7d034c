"""MkDocs hook (mkdocs.yml: ``hooks:``): the site's home page is the README.

``docs/index.md`` is a stub; its content is README.md at build time, with the README's links into
``docs/`` made relative to the site (``docs/push.md`` -> ``push.md``) and the title spelled out.
One text, so the front page on GitHub and the site's home never drift apart, and
``mkdocs build --strict`` checks the README's links and anchors like any page's.
"""

from __future__ import annotations

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def readme_as_home(text: str) -> str:
    """README.md's text as the site's home page."""
    text = re.sub(r"\]\(docs/", "](", text)
    text = text.replace(
        "The documentation is a site built from `docs/`", "This site is built from `docs/`", 1
    )
    return re.sub(r"^# biped\s*$", "# biped: balance control of human-like bipeds", text, count=1, flags=re.M)


def on_page_markdown(markdown, page, config, files):  # noqa: ARG001 - MkDocs' hook signature
    if page.file.src_uri == "index.md":
        return readme_as_home(README.read_text(encoding="utf-8"))
    return markdown
