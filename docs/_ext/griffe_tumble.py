"""A Griffe extension that reads tumble's docstrings as Markdown for the API reference.

tumble's docstrings are plain text: "name : meaning" lines for parameters and fields, a few
reST roles (:class:`Recorder`), ``double backticks`` and, in a handful, numpy-style section
underlines. mkdocstrings is set to ``docstring_style: null`` (the text is Markdown) and this
extension rewrites what Markdown would misread, without touching the source files:

* ``:class:`~tumble.viewer.scene.Scene``` -> ```Scene``` (``~`` keeps the last name);
* a section title underlined with dashes -> a bold title;
* "name : meaning" lines at the left margin -> list items (a blank line before the first;
  two on one line, after a full stop and two spaces, become two);
* a paragraph ending in ``::`` (reST's literal block) -> ``:``.
"""
import re

import griffe

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|attr|data|obj|exc):`(~?)([^`]+)`")
_FIELD = re.compile(r"^([A-Za-z_*][\w.*]*(?:\s*,\s*[A-Za-z_*][\w.*]*)*)\s+:\s+(\S.*)$")
_UNDERLINE = re.compile(r"^\s*-{3,}\s*$")
# "a : one.  b : two." on one line: two fields
_SECOND_FIELD = re.compile(r"(?<=[.)])\s{2,}(?=[A-Za-z_][\w]*(?:, [A-Za-z_]\w*)* : )")


def _role(match):
    tilde, target = match.groups()
    return f"`{target.rsplit('.', 1)[-1] if tilde else target}`"


def to_markdown(text):
    """tumble's docstring dialect as Markdown (see the module notes)."""
    text = _ROLE.sub(_role, text)
    lines = []
    for line in text.split("\n"):
        lines += _SECOND_FIELD.split(line) if _FIELD.match(line) else [line]
    out = []
    in_list = False
    i = 0
    while i < len(lines):
        line = lines[i]
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() and _UNDERLINE.match(nxt) and not line.startswith(" "):
            if out and out[-1].strip():
                out.append("")
            out += [f"**{line.strip()}**", ""]
            in_list = False
            i += 2
            continue
        m = _FIELD.match(line)
        if m:
            if not in_list and out and out[-1].strip():
                out.append("")
            names = ", ".join(f"`{n.strip()}`" for n in m.group(1).split(","))
            out.append(f"- {names}: {m.group(2)}")
            in_list = True
        else:
            if not line.strip() or not line.startswith(" "):
                in_list = in_list and line.startswith(" ")
            if line.rstrip().endswith("::") and not line.startswith(" "):
                line = line.rstrip()[:-1]
            out.append(line)
        i += 1
    return "\n".join(out)


class TumbleDocstrings(griffe.Extension):
    """Rewrites every docstring as it is loaded (see the module notes)."""

    def on_instance(self, *, obj, **kwargs):
        if obj.docstring is not None:
            obj.docstring.value = to_markdown(obj.docstring.value)
