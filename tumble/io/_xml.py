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

import numpy as np

from ..errors import ModelError
from ._files import file_path, mib, read_file


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


#: Most bytes of XML one model may hold (its file and, for MJCF, every included file,
#: counted each time it is included).
MAX_XML_BYTES = 32 * 2 ** 20
#: Most elements one model may hold (after MJCF includes are expanded).
MAX_ELEMENTS = 200_000
#: Deepest nesting of XML elements (MuJoCo's own XML reader stops at 500).
MAX_DEPTH = 1000


class Budget:
    """What one load has used of the caps above: bytes and elements, over all its files."""

    __slots__ = ("bytes", "elements")

    def __init__(self):
        self.bytes = 0
        self.elements = 0

    def add_bytes(self, n, name):
        self.bytes += n
        if self.bytes > MAX_XML_BYTES:
            raise ModelError(f"{name}: the model holds more than {mib(MAX_XML_BYTES)} of XML "
                             f"(with its includes), the most tumble reads "
                             f"(tumble.io._xml.MAX_XML_BYTES)")


def parse_xml(source, what, budget=None):
    """Parse a file path or an XML string (anything starting with '<') into a root Node.

    Returns ``(root, base_dir, name)``: the directory relative file references resolve
    against (the file's directory; the working directory for strings) and a short
    name for messages. Malformed XML raises ModelError with the line and column; so do a
    missing, unreadable or oversized file, a NUL byte in the path and a tree nested deeper
    than ``MAX_DEPTH`` or with more than ``MAX_ELEMENTS`` elements.
    """
    budget = Budget() if budget is None else budget
    if isinstance(source, (bytes, bytearray)):
        if bytes(source[:4096]).lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<"):
            budget.add_bytes(len(source), "<string>")
            return parse_xml_text(bytes(source), "<string>", budget), os.getcwd(), "<string>"
        source = os.fsdecode(bytes(source))
    if isinstance(source, str) and source.lstrip().lstrip("\ufeff").startswith("<"):
        budget.add_bytes(len(source), "<string>")
        return parse_xml_text(source, "<string>", budget), os.getcwd(), "<string>"
    if not isinstance(source, (str, os.PathLike)):
        raise ModelError(f"{what}: expected a file path or an XML string, got "
                         f"{type(source).__name__}")
    path = file_path(source, what)
    data = read_file(path, what, MAX_XML_BYTES, cap_name="tumble.io._xml.MAX_XML_BYTES")
    name = os.path.basename(path)
    budget.add_bytes(len(data), name)
    return parse_xml_text(data, name, budget), os.path.dirname(os.path.abspath(path)), name


def parse_xml_text(data, name, budget=None):
    """Parse XML text (str or bytes) into a root Node; ``name`` labels messages.

    ``budget`` (a :class:`Budget`) counts elements over every file of one load."""
    budget = Budget() if budget is None else budget
    parser = xml.parsers.expat.ParserCreate()
    stack = []
    root = []

    def start(tag, attrib):
        line = parser.CurrentLineNumber
        if len(stack) >= MAX_DEPTH:
            raise ModelError(f"{name} line {line}, <{tag}>: elements nested more than "
                             f"{MAX_DEPTH} deep, the most tumble reads "
                             f"(tumble.io._xml.MAX_DEPTH)")
        budget.elements += 1
        if budget.elements > MAX_ELEMENTS:
            raise ModelError(f"{name} line {line}, <{tag}>: the model has more than "
                             f"{MAX_ELEMENTS} elements (with its includes), the most tumble "
                             f"reads (tumble.io._xml.MAX_ELEMENTS)")
        node = Node(tag, attrib, name, line, stack[-1] if stack else None)
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
    except UnicodeError as e:
        # a str holding what UTF-8 cannot encode (lone surrogates from a bad decode)
        text = data if isinstance(data, str) else ""
        at = getattr(e, "start", 0)
        line = text.count("\n", 0, at) + 1
        raise ModelError(f"{name} line {line}: malformed XML: character "
                         f"{text[at:at + 1]!r} cannot be encoded ({e.reason})") from None
    if not root:
        raise ModelError(f"{name}: malformed XML: no element found")
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


def norm(v):
    """Euclidean norm of a finite vector without overflow (1e200 components stay finite)."""
    v = np.asarray(v, float)
    m = float(np.max(np.abs(v))) if v.size else 0.0
    return 0.0 if m == 0.0 else m * float(np.linalg.norm(v / m))


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
