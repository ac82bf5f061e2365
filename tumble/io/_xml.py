"""A small XML tree that remembers where each element came from, for the model loaders.

``xml.etree`` drops line numbers, and the loaders must name the line of a bad element,
so this reads the file with the standard library's expat parser into :class:`Node`
objects (tag, attributes, children, file and line). Attribute readers here raise
``ModelError`` messages of the form ``"<file> line <n>: <joint name='knee'>: attribute
'range': ..."``.
"""
import math
import os
import xml.parsers.expat

from ..errors import ModelError


class Node:
    """One XML element: ``tag``, ``attrib`` (dict of str), ``children`` (list of Node),
    ``source`` (file name or '<string>') and ``line`` (1-based)."""

    __slots__ = ("tag", "attrib", "children", "source", "line", "parent")

    def __init__(self, tag, attrib, source, line, parent=None):
        self.tag = tag
        self.attrib = dict(attrib)
        self.children = []
        self.source = source
        self.line = line
        self.parent = parent

    def __repr__(self):
        return f"<Node {self.tag} {self.source}:{self.line}>"

    def label(self):
        """``<joint name='knee'>`` (the name only when the element has one)."""
        name = self.attrib.get("name")
        return f"<{self.tag} name='{name}'>" if name else f"<{self.tag}>"

    def where(self):
        """Location prefix for messages: ``"humanoid.xml line 34, <joint name='knee'>"``."""
        return f"{self.source} line {self.line}, {self.label()}"

    def error(self, message, attr=None):
        """A ModelError naming this element (and ``attr``) and its line."""
        field = f": attribute '{attr}':" if attr else ":"
        return ModelError(f"{self.where()}{field} {message}")

    def find(self, tag):
        """First child with this tag, or None."""
        for c in self.children:
            if c.tag == tag:
                return c
        return None

    def findall(self, tag):
        return [c for c in self.children if c.tag == tag]


def parse_xml(source, what):
    """Parse a file path or an XML string (anything starting with '<') into a root Node.

    Returns ``(root, base_dir, name)``: the directory relative file references resolve
    against (the file's directory; the working directory for strings) and a short
    name for messages. Malformed XML raises ModelError with the line and column.
    """
    if isinstance(source, bytes):
        source = source.decode("utf-8")
    if isinstance(source, str) and source.lstrip().startswith("<"):
        return parse_xml_text(source, "<string>"), os.getcwd(), "<string>"
    if not isinstance(source, (str, os.PathLike)):
        raise ModelError(f"{what}: expected a file path or an XML string, got "
                         f"{type(source).__name__}")
    path = os.fspath(source)
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise ModelError(f"{what}: cannot read '{path}': {e.strerror or e}") from None
    name = os.path.basename(path)
    return parse_xml_text(data, name), os.path.dirname(os.path.abspath(path)), name


def parse_xml_text(data, name):
    """Parse XML text (str or bytes) into a root Node; ``name`` labels messages."""
    parser = xml.parsers.expat.ParserCreate()
    stack = []
    root = []

    def start(tag, attrib):
        node = Node(tag, attrib, name, parser.CurrentLineNumber, stack[-1] if stack else None)
        if stack:
            stack[-1].children.append(node)
        else:
            root.append(node)
        stack.append(node)

    def end(tag):
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as e:
        raise ModelError(f"{name} line {e.lineno}, column {e.offset + 1}: malformed XML: "
                         f"{xml.parsers.expat.ErrorString(e.code)}") from None
    return root[0]


# ---------------------------------------------------------------- attribute readers
def floats(node, attr, value, n=None, min_n=None, max_n=None):
    """The whitespace-separated numbers of ``value`` as a list of floats.

    ``n``: exactly that many; ``min_n``/``max_n``: a range. Refuses non-numbers and
    non-finite values with the element, attribute and line.
    """
    parts = value.split()
    out = []
    for p in parts:
        try:
            v = float(p)
        except ValueError:
            raise node.error(f"'{p}' is not a number (value '{value}')", attr) from None
        if not math.isfinite(v):
            raise node.error(f"'{p}' is not finite", attr)
        out.append(v)
    lo = n if n is not None else (min_n or 0)
    hi = n if n is not None else max_n
    if len(out) < lo or (hi is not None and len(out) > hi):
        want = (f"{n}" if n is not None else
                f"{lo} to {hi}" if hi is not None else f"at least {lo}")
        raise node.error(f"expected {want} numbers, got {len(out)} ('{value}')", attr)
    return out


def boolean(node, attr, value, allow_auto=False):
    """'true'/'false' (and 'auto' when allowed) -> True/False/'auto'."""
    v = value.strip().lower()
    if v == "true":
        return True
    if v == "false":
        return False
    if allow_auto and v == "auto":
        return "auto"
    choices = "'true', 'false'" + (" or 'auto'" if allow_auto else "")
    raise node.error(f"must be {choices}, got '{value}'", attr)


def choice(node, attr, value, options):
    if value not in options:
        raise node.error(f"must be one of {sorted(options)}, got '{value}'", attr)
    return value
