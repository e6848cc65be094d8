"""A griffe extension for the API reference: the docstrings' reStructuredText as Markdown.

The package's docstrings write ``:class:`~modelicagym.vector.PoolVectorEnv```, ``double
backticks`` and literal blocks (a paragraph ending in ``::``, then an indented block) as Sphinx
reads them; Markdown would show a role's name verbatim and run a literal block into the text. This
turns ``:role:`~a.b.C``` and `` `~a.b.C` `` into `` `C` `` (``:role:`a.b.C``` into `` `a.b.C` ``), ``x`` into
`` `x` ``, and a literal block into a fenced code block.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|attr|exc|data|obj|ref):`(~?)([^`]+)`")
DOUBLE = re.compile(r"``([^`]+)``")
TILDE = re.compile(r"(?<!`)`~([\w.]+)`(?!`)")


def _role(match: re.Match[str]) -> str:
    target = match.group(2)
    return f"`{target.rsplit('.', 1)[-1] if match.group(1) else target}`"


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def fenced(text: str) -> str:
    """Each literal block (after a line ending in ``::``) as a fenced code block."""
    lines, out, i = text.splitlines(), [], 0
    while i < len(lines):
        line = lines[i]
        i += 1
        if not line.rstrip().endswith("::"):
            out.append(line)
            continue
        head = line.rstrip()[:-2].rstrip()
        if head.strip() in ("Example", "Examples"):
            head = head.replace("Example", "For example").rstrip("s") + ":"
        elif head.strip():
            head += ":"
        if head.strip():
            out.append(head)
        base = _indent(line)
        block = []
        while i < len(lines) and (not lines[i].strip() or _indent(lines[i]) > base):
            block.append(lines[i])
            i += 1
        while block and not block[-1].strip():
            block.pop()
        while block and not block[0].strip():
            block.pop(0)
        body = [b for b in block if b.strip()]
        cut = min((_indent(b) for b in body), default=0)
        pad = " " * base
        out += ["", pad + "```"] + [pad + b[cut:] if b.strip() else "" for b in block]
        out += [pad + "```", ""]
    return "\n".join(out)


def doctests(text: str) -> str:
    """Each doctest (``>>>`` lines and their output, up to a blank line) as a fenced ``pycon`` block."""
    lines, out, i = text.splitlines(), [], 0
    while i < len(lines):
        if not lines[i].lstrip().startswith(">>>"):
            out.append(lines[i])
            i += 1
            continue
        pad = " " * _indent(lines[i])
        title = bool(out) and out[-1].rstrip().endswith(":")  # a section's first lines: no blank line between
        out += ([] if title else [""]) + [pad + "```pycon"]
        while i < len(lines) and lines[i].strip():
            out.append(pad + lines[i][len(pad):])
            i += 1
        out += [pad + "```", ""]
    return "\n".join(out)


def plain(text: str) -> str:
    text = TILDE.sub(lambda match: f"`{match.group(1).rsplit('.', 1)[-1]}`", ROLE.sub(_role, text))
    return doctests(fenced(DOUBLE.sub(r"`\1`", text)))


class SphinxRoles(griffe.Extension):
    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = plain(obj.docstring.value)
