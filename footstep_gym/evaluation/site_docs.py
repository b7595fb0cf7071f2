"""docs/benchmark.md as the site's pages: the protocol, and its "submitting a method" section on a page of its own.

Rendered with markdown-it-py (CommonMark and tables); headings get GitHub's anchors so the document's own
links work; an image of the repository is copied into the site, a link to another page of the docs that the
site renders is pointed there, and a link to any other file of the repository is left as its text (the site
holds no source files). External images are dropped: the site fetches nothing.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from markdown_it import MarkdownIt

__all__ = ["github_anchor", "render_protocol", "SUBMIT_HEADING"]

#: The heading of docs/benchmark.md whose section is the "submit your method" page.
SUBMIT_HEADING = re.compile(r"^## \d+\. Submitting", re.M)
#: docs pages the site renders, and where.
PAGES = {"benchmark.md": "protocol.html"}


def github_anchor(text: str) -> str:
    """GitHub's heading anchor: lower case, punctuation but ``-`` and ``_`` dropped, spaces made ``-``."""
    return re.sub(r"[^\w\- ]", "", text.strip().lower()).replace(" ", "-")


def _renderer(doc_dir: Path, out: Path) -> MarkdownIt:
    md = MarkdownIt("commonmark", {"html": True}).enable("table")

    def core(state) -> None:  # type: ignore[no-untyped-def]
        tokens = state.tokens
        for i, tok in enumerate(tokens):
            if tok.type == "heading_open":
                tok.attrSet("id", github_anchor(tokens[i + 1].content))
            if tok.type != "inline" or not tok.children:
                continue
            kids = []
            drop_close = 0
            for child in tok.children:
                if child.type == "image":
                    src = str(child.attrGet("src") or "")
                    local = (doc_dir / src).resolve()
                    if re.match(r"^[a-z]+:", src) or not local.is_file():
                        continue  # nothing external, nothing missing
                    dst = out / "assets/docs" / local.name
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copyfile(local, dst)
                    child.attrSet("src", f"assets/docs/{local.name}")
                elif child.type == "link_open":
                    href = str(child.attrGet("href") or "")
                    name, _, frag = href.partition("#")
                    if href.startswith("#") or re.match(r"^[a-z]+:", href):
                        pass
                    elif Path(name).name in PAGES and (doc_dir / name).resolve().parent == doc_dir.resolve():
                        child.attrSet("href", PAGES[Path(name).name] + (f"#{frag}" if frag else ""))
                    else:  # a file of the repository: its text stays, the link goes
                        drop_close += 1
                        continue
                elif child.type == "link_close" and drop_close:
                    drop_close -= 1
                    continue
                kids.append(child)
            tok.children = kids

    md.core.ruler.push("site_links", core)
    return md


def render_protocol(path: Path, out: Path) -> tuple[str, str]:
    """``(protocol, submit)``: the HTML of the whole document and of its "Submitting" section (or, where it has none,
    a pointer to the protocol page); images it shows are copied under ``out/assets/docs``."""
    text = path.read_text(encoding="utf-8")
    md = _renderer(path.parent, out)
    match = SUBMIT_HEADING.search(text)
    if match is None:  # the document was reorganised: the submit page sends the reader to it whole
        return md.render(text), ('<p>How to submit a method is part of <a href="protocol.html">the protocol</a> '
                                 f"(<code>docs/{path.name}</code>).</p>")
    nxt = re.search(r"^## ", text[match.end():], re.M)
    section = text[match.start(): match.end() + nxt.start()] if nxt else text[match.start():]
    return md.render(text), md.render(section)
