"""Hostile XML: what an expat parser must refuse before it reads outside the file or expands
entities without bound (an SVG's DOCTYPE; used by `svg_tree.load_tree`).

expat never loads an external DTD or entity unless given a loader, and none is given here; the
handlers below turn every place where a file *asks* for one into an error naming it, and keep
what internal entities may expand to small, whatever expat's own amplification limit is (the
Pi's libexpat may be older than the one that has it).
"""

from __future__ import annotations

from vplotter.errors import InputError

ENTITY_MAX_CHARS = 1024     # an internal entity's value, at most (Illustrator's are ~50)
ENTITY_MAX_COUNT = 64       # entity declarations, at most
EXPANDED_MAX = 1 << 22      # attribute and text characters beyond the file's own, at most
UNZIPPED_MAX = 1 << 27      # bytes an .svgz may decompress to (128 MiB; a bomb's are GBs)


def guard_entities(parser, path: str) -> None:
    """Make `parser` refuse what could read outside the file or blow up in memory: external
    entities (SYSTEM/PUBLIC, general or parameter), parameter entities, entity references the
    file does not declare (an external DTD is never read: expat is not given a loader), and
    internal entities that refer to other entities (the billion laughs) or are long; plain
    internal entities (Illustrator's namespace names) are kept, and once a file declares one,
    what its attributes and text expand to beyond the file's own bytes is bounded. A refusal
    is an InputError at the place in the file (raised from a handler, it leaves the parse)."""
    count = [0, 0]          # declarations, expanded characters

    def refuse(msg: str):
        raise InputError(f"{path}:{parser.CurrentLineNumber}:{parser.CurrentColumnNumber + 1}: "
                         f"error: {msg}")

    def entity_decl(name, is_param, value, base, system_id, public_id, notation):
        count[0] += 1
        if system_id is not None or public_id is not None or notation is not None:
            refuse(f"external entity {name!r} ({system_id or public_id}): entities that read "
                   f"other files are not accepted")
        if is_param:
            refuse(f"parameter entity {name!r}: parameter entities are not accepted")
        if "&" in value or "%" in value:
            refuse(f"entity {name!r} refers to other entities (an entity-expansion bomb?): "
                   f"not accepted")
        if len(value) > ENTITY_MAX_CHARS or count[0] > ENTITY_MAX_COUNT:
            refuse(f"entity {name!r}: at most {ENTITY_MAX_COUNT} entities of at most "
                   f"{ENTITY_MAX_CHARS} characters are accepted")
        if count[0] == 1:       # from now on, bound what the references expand to
            start, chars = parser.StartElementHandler, parser.CharacterDataHandler

            def counted(n: int) -> None:
                count[1] += n
                if count[1] > parser.CurrentByteIndex + EXPANDED_MAX:
                    refuse(f"entities expand to more than {EXPANDED_MAX} characters")

            def start_counted(name, attrs):
                counted(sum(len(v) for v in attrs.values()))
                start(name, attrs)

            def chars_counted(data):
                counted(len(data))
                chars(data)

            parser.StartElementHandler = start_counted
            parser.CharacterDataHandler = chars_counted

    def skipped(name, is_param):
        refuse(f"entity {'%' if is_param else '&'}{name}; is not declared in the file "
               f"(external DTDs are not read)")

    def external(context, base, system_id, public_id):
        refuse(f"external reference {system_id or public_id!r}: not read")

    parser.EntityDeclHandler = entity_decl
    parser.SkippedEntityHandler = skipped
    parser.ExternalEntityRefHandler = external
    parser.UnparsedEntityDeclHandler = (
        lambda name, base, system_id, public_id, notation:
        refuse(f"external entity {name!r} ({system_id}): not accepted"))


class Bounded:
    """A file object for expat's ParseFile that refuses to read more than UNZIPPED_MAX bytes
    (an .svgz decompression bomb: a few MB of gzip that inflate to GBs of whitespace)."""

    def __init__(self, f, path: str, limit: int | None = None):
        self.f, self.path, self.done = f, path, 0
        self.limit = UNZIPPED_MAX if limit is None else limit

    def read(self, n: int = -1) -> bytes:
        room = self.limit - self.done + 1        # one byte more than allowed tells a bomb
        data = self.f.read(n if 0 <= n <= room else room)
        self.done += len(data)
        if self.done > self.limit:
            raise InputError(f"{self.path}: error: decompresses to more than "
                             f"{self.limit / (1 << 20):g} MB (a decompression bomb?): not read")
        return data
