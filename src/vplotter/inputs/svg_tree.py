"""An SVG file's XML as a tree of Nodes (expat: each element keeps its line and column for
messages), with hostile DOCTYPEs refused (`xml_guard.py`) and .svgz read through gzip; the text
to draw is counted as it is read, so that too much of it is refused before any layout."""

from __future__ import annotations

from vplotter.errors import InputError, unreadable
from vplotter.inputs import xml_guard

SVG_NS = "http://www.w3.org/2000/svg"
PREFIXES = {"http://www.inkscape.org/namespaces/inkscape": "inkscape:",
            "http://www.w3.org/1999/xlink": "xlink:",
            "http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd": "sodipodi:",
            "http://www.w3.org/XML/1998/namespace": "xml:"}
# elements whose character data is text to draw: their Node.text holds strings and child Nodes
# in document order
TEXT_CONTENT = {"text", "tspan", "textPath", "a", "flowRoot", "flowPara", "flowSpan",
                "flowDiv", "flowLine"}


class Node:
    __slots__ = ("tag", "svg", "attrs", "children", "text", "line", "col", "num")

    def __init__(self, tag, svg, attrs, line, col, num):
        self.tag, self.svg, self.attrs = tag, svg, attrs
        self.children: list[Node] = []
        self.text: list[str] = []
        self.line, self.col, self.num = line, col, num

    def src(self) -> str:
        return self.attrs.get("id") or f"{self.tag}#{self.num}"


def _qualify(name: str) -> tuple[str, str]:
    """'uri local' (expat with a namespace separator) -> (uri, local)."""
    uri, _, local = name.rpartition(" ")
    return uri, local


def load_tree(path: str) -> tuple[Node, dict[str, Node]]:
    """Parse the file into Nodes (every element numbered 1, 2, ... in document order) and the
    id table (the first element with an id wins)."""
    import gzip
    import zlib
    from xml.parsers import expat

    parser = expat.ParserCreate(namespace_separator=" ")
    stack: list[Node] = []
    ids: dict[str, Node] = {}
    holder: list[Node] = []
    root_uri: list[str] = []
    numbered: list[Node] = []

    def start(name, attrs):
        uri, tag = _qualify(name)
        if not stack:
            root_uri.append(uri)
        # a file without xmlns is taken as SVG throughout; otherwise only the SVG namespace
        svg = uri == SVG_NS or (uri == "" and root_uri[0] == "")
        plain = {}
        for key, value in attrs.items():
            kuri, local = _qualify(key)
            plain[PREFIXES.get(kuri, f"{{{kuri}}}" if kuri else "") + local] = value
        numbered.append(node := Node(tag, svg, plain, parser.CurrentLineNumber,
                                     parser.CurrentColumnNumber + 1, len(numbered) + 1))
        if stack:
            stack[-1].children.append(node)
            if stack[-1].tag in TEXT_CONTENT:
                stack[-1].text.append(node)
        else:
            holder.append(node)
        stack.append(node)
        ident = plain.get("id")
        if ident and ident not in ids:
            ids[ident] = node

    def end(name):
        stack.pop()

    written = [0]                     # characters of text, spaces aside (a bound, checked
                                      # before any layout: 200,000 took 8 s to refuse)

    def chars(data):
        if stack and (stack[-1].tag == "style" or stack[-1].tag in TEXT_CONTENT):
            stack[-1].text.append(data)
            if stack[-1].tag != "style":
                written[0] += len(data) - sum(map(data.count, " \t\n\r"))

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    xml_guard.guard_entities(parser, path)      # refuses external and exploding entities
    try:
        with open(path, "rb") as f:
            if f.read(2) == b"\x1f\x8b":              # .svgz: gzip-compressed SVG
                f.seek(0)
                with gzip.GzipFile(fileobj=f) as z:
                    parser.ParseFile(xml_guard.Bounded(z, path))
            else:
                f.seek(0)
                parser.ParseFile(f)
    except (gzip.BadGzipFile, EOFError, zlib.error) as e:
        raise InputError(f"{path}: error: not a valid gzip-compressed SVG (.svgz): {e}") from None
    except expat.ExpatError as e:
        raise InputError(f"{path}:{e.lineno}:{e.offset + 1}: error: not well-formed XML: "
                         f"{expat.ErrorString(e.code)}") from None
    except OSError as e:
        raise unreadable(path, e, "an SVG file") from None
    root = holder[0]
    if root.tag != "svg" or not root.svg:
        raise InputError(f"{path}:{root.line}:{root.col}: error: not an SVG file (the root "
                         f"element is <{root.tag}>, not <svg>)")
    from vplotter.inputs import text

    text.too_many(written[0], path)
    return root, ids
