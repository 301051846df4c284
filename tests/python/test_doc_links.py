"""Every relative link in README.md and docs/**/*.md leads somewhere: the file (or folder) it
names exists, and a `#anchor` matches a heading of the file it points into under GitHub's slug
rules (lowercase; punctuation except - and _ removed; spaces to -; a repeated heading gets -1,
-2, ...). A broken link is reported as FILE:LINE: LINK and what is wrong with it.
Usage: test_doc_links.py [ROOT] (default: this source tree)."""
import os
import re
import sys
import urllib.parse

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from checks import check, done  # noqa: E402

FENCE = re.compile(r"^\s{0,3}(`{3,}|~{3,})")
HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
# the target of [text](target "title") and ![alt](target), found by its "](" alone so that a link
# whose text is wrapped over lines counts too
INLINE = re.compile(r"\]\(\s*<([^>]*)>|\]\(\s*([^\s()]*(?:\([^\s()]*\)[^\s()]*)*)")
REFDEF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+.*)?$")
CODESPAN = re.compile(r"(`+)(.+?)\1")
HTML_ID = re.compile(r"<a\s+[^>]*(?:name|id)\s*=\s*\"([^\"]+)\"", re.I)


def markdown_files(root):
    files = [os.path.join(root, "README.md")]
    for d, _, names in os.walk(os.path.join(root, "docs")):
        files += [os.path.join(d, n) for n in names if n.endswith(".md")]
    return sorted(f for f in files if os.path.isfile(f))


def prose_lines(path):
    """(line number, text) of the lines outside fenced code blocks."""
    fence = None
    with open(path, encoding="utf-8") as f:
        for i, line in enumerate(f, 1):
            m = FENCE.match(line)
            if m:
                if fence is None:
                    fence = m.group(1)
                elif m.group(1)[0] == fence[0] and len(m.group(1)) >= len(fence):
                    fence = None
                continue
            if fence is None:
                yield i, line.rstrip("\n")


def slug(text):
    """GitHub's anchor for a heading's text."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link shows its text
    text = re.sub(r"<[^>]+>", "", text)                     # inline HTML tags
    text = text.strip().lower()
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


_anchors = {}


def anchors(path):
    if path not in _anchors:
        seen, found = {}, set()
        for _, line in prose_lines(path):
            m = HEADING.match(line)
            if m:
                base = slug(m.group(2))
                n = seen.get(base, 0)
                seen[base] = n + 1
                found.add(base if n == 0 else f"{base}-{n}")
            for a in HTML_ID.findall(line):
                found.add(a)
        _anchors[path] = found
    return _anchors[path]


def links(line):
    """The link targets on a line of prose (code spans left out)."""
    bare = CODESPAN.sub(lambda m: " " * len(m.group(0)), line)
    targets = [m.group(1) or m.group(2) for m in INLINE.finditer(bare)]
    m = REFDEF.match(bare)
    if m:
        targets.append(m.group(1))
    return targets


def problem(src, target, root):
    """What is wrong with a link target in file src, or None."""
    if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I) or target.startswith("//"):
        return None  # http:, https:, mailto: ...: not checked here
    path, _, frag = target.partition("#")
    path = urllib.parse.unquote(path)
    if path.startswith("/"):
        dest = os.path.normpath(os.path.join(root, path.lstrip("/")))
    else:
        dest = os.path.normpath(os.path.join(os.path.dirname(src), path)) if path else src
    if not os.path.exists(dest):
        return f"no such file {os.path.relpath(dest, root)}"
    if frag:
        if not dest.endswith(".md") or os.path.isdir(dest):
            return None
        if urllib.parse.unquote(frag) not in anchors(dest):
            return f"no heading #{frag} in {os.path.relpath(dest, root)}"
    return None


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "..", ".."))
    files = markdown_files(root)
    check(len(files) > 1, f"{root}: no README.md and docs/*.md found")
    total = 0
    for src in files:
        for lineno, line in prose_lines(src):
            for target in links(line):
                total += 1
                why = problem(src, target, root)
                check(why is None, f"{os.path.relpath(src, root)}:{lineno}: ({target}): {why}")
    print(f"{total} links in {len(files)} files")
    check(total > 0, "no links found")
    return done()


if __name__ == "__main__":
    sys.exit(main())
