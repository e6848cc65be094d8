"""A griffe extension for the API reference: the docstrings' reStructuredText as Markdown, their
references as links.

The package's docstrings write ``:class:`~modelicagym.vector.PoolVectorEnv```, `` `FMUEnvConfig` ``
(Sphinx's default role: a reference), ``double backticks`` (a literal) and literal blocks (a
paragraph ending in ``::``, then an indented block) as Sphinx reads them; Markdown would show a
role's name verbatim and run a literal block into the text. This turns

* a reference (``:role:`target``` or `` `target` ``) into a link to the target's entry, its name
  resolved as Python would in the docstring's scope (`` `compute_reward` `` in a method of
  `FMUEnv` is ``FMUEnv.compute_reward``); ``~`` shows the last part only. A target the reference
  does not document is shown as code, without a link;
* ``x`` into `` `x` ``;
* a literal block into a fenced code block (Python after ``Example::``), and a doctest into a
  fenced ``pycon`` block.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from html import escape
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|attr|exc|data|obj|ref):`(~?)([^`]+)`")
REFERENCE = re.compile(r"(?<!`)`(~?)([A-Za-z_][\w.]*)(\(\))?`(?!`)")
DOUBLE = re.compile(r"``([^`]+)``")
FENCE = re.compile(r"^\s*```")

#: a reference's target, as a full path, or None when it names nothing known
Resolver = Callable[[str], "str | None"]


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def fenced(text: str) -> str:
    """Each literal block (after a line ending in ``::``) as a fenced code block: Python after
    ``Example::`` (shown as "For example:"), plain text after any other paragraph."""
    lines, out, i = text.splitlines(), [], 0
    while i < len(lines):
        line = lines[i]
        i += 1
        if not line.rstrip().endswith("::"):
            out.append(line)
            continue
        head = line.rstrip()[:-2].rstrip()
        language = "text"
        if head.strip() in ("Example", "Examples"):
            head, language = head.replace("Example", "For example").rstrip("s") + ":", "python"
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
        out += ["", pad + "```" + language] + [pad + b[cut:] if b.strip() else "" for b in block]
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


def _prose(text: str) -> Iterator[tuple[bool, str]]:
    """The text's lines in runs, each flagged whether it is prose (outside fenced code blocks)."""
    run: list[str] = []
    in_code = False
    for line in text.split("\n"):
        if FENCE.match(line):
            if run:
                yield not in_code, "\n".join(run)
            run, in_code = [], not in_code
            yield False, line
            continue
        run.append(line)
    if run:
        yield not in_code, "\n".join(run)


def _link(match: re.Match[str], resolve: Resolver) -> str:
    short, name, call = match.group(1), match.group(2), match.group(3) or ""
    title = escape((name.rsplit(".", 1)[-1] if short else name) + call)
    target = resolve(name)
    if target is None:
        return f"`{title}`"
    # optional: a target without an entry in the reference is shown as code, without a warning
    return f'<autoref identifier="{escape(target)}" optional><code>{title}</code></autoref>'


def plain(text: str, resolve: Resolver = lambda name: None) -> str:
    """The docstring ``text`` as Markdown; ``resolve`` gives a reference's target (see the module)."""
    text = doctests(fenced(text))
    parts = []
    for prose, part in _prose(text):
        if prose:
            part = ROLE.sub(lambda match: f"`{match.group(1)}{match.group(2)}`", part)
            part = DOUBLE.sub(r"`\1`", REFERENCE.sub(lambda match: _link(match, resolve), part))
        parts.append(part)
    return "\n".join(parts)


def resolver(obj: griffe.Object) -> Resolver:
    """Names as Python resolves them in ``obj``'s scope (its members, its parents', their imports);
    a dotted name by its first part, or as a full path when that part is no name there."""

    def resolve(name: str) -> str | None:
        head, _, rest = name.partition(".")
        try:
            path = obj.resolve(head)
        except griffe.NameResolutionError:
            return name if rest else None
        return f"{path}.{rest}" if rest else path

    return resolve


def _objects(obj: griffe.Object) -> Iterator[griffe.Object]:
    """``obj`` and every object defined in it (not what it imports)."""
    yield obj
    for member in obj.members.values():
        if not member.is_alias:
            yield from _objects(member)


class SphinxRoles(griffe.Extension):
    """Rewrites every docstring of a loaded package once the package is whole, so that a reference
    resolves to a name defined anywhere in it."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        for obj in _objects(pkg):
            if obj.docstring is not None:
                obj.docstring.value = plain(obj.docstring.value, resolver(obj))
