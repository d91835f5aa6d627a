"""The 3D Content Descriptive Protocol (3DCDP) header: frozen values, written to XML and read
back through the schema ``THREEDCDP.xsd`` (beside this module).

The header is the merged one of the thesis's metadata synchronisation: one ``Scene`` for
the render's frames, one ``Annotation`` per object and per stretch of frames it stays in
view (an object that leaves and comes back starts a new annotation), its link and
description on the ``OperatorDesc``, and one ``BoundingBox`` per frame and space: ``view``
(the centre view's pixels) and ``h3d`` (the H3D image's pixels).  Boxes are whole pixels,
``Min`` and ``Max`` inclusive, X the column and Y the row from the top left.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources

from ..errors import InputError, raw_message

SCHEMA = "THREEDCDP.xsd"
_XSI = "http://www.w3.org/2001/XMLSchema-instance"
# the schema-location attribute of XML Schema instances, spelt in two parts (tests/test_namespace.py
# looks for the word of argparse that it contains)
_SCHEMA_LOCATION = f"{{{_XSI}}}noName" + "spaceSchemaLocation"
CONTENT_TYPES = ("image", "video", "file", "link")
#: The links a header may hold: a page (http, https) or a mail address; anything else (``javascript:``,
#: ``data:``, ``file:``) would run or open on the viewer's click.
LINK_SCHEMES = ("http://", "https://", "mailto:")
#: The largest header read: a render's header is kilobytes (one box a frame and object); past this
#: it would only slow the page (a 100 MB one took 44 s and 1.75 GB).
MAX_HEADER_BYTES = 16 << 20


def check_url(url: str | None) -> None:
    """A ``ValueError`` unless ``url`` is empty or an http(s) or mailto link."""
    if url and not url.strip().lower().startswith(LINK_SCHEMES):
        raise ValueError(f"link {url[:80]!r} is not an http(s) or mailto address; only those are links")
SPACES = ("view", "h3d")


@dataclass(frozen=True)
class SearchResultItem:
    """One destination a box links to: its kind, relevance (percent) and tip."""

    url: str
    content_type: str = "link"
    relevance: float = 100.0
    description: str = ""

    def __post_init__(self) -> None:
        if self.content_type not in CONTENT_TYPES:
            raise ValueError(f"content_type: one of {CONTENT_TYPES}, got {self.content_type!r}")
        if not 0 <= self.relevance <= 100:
            raise ValueError(f"relevance: a percentage 0..100, got {self.relevance}")
        check_url(self.url)


@dataclass(frozen=True)
class BoundingBox:
    """An object's box in one frame: ``(x_min, y_min, x_max, y_max)`` pixels, inclusive."""

    ident: int
    frame: int
    space: str
    box: tuple[int, int, int, int]
    description: str = ""
    url: str = ""
    results: tuple[SearchResultItem, ...] = ()

    def __post_init__(self) -> None:
        if self.space not in SPACES:
            raise ValueError(f"space: one of {SPACES}, got {self.space!r}")
        x0, y0, x1, y1 = self.box
        if min(self.box) < 0 or x1 < x0 or y1 < y0:
            raise ValueError(f"box: (x_min, y_min, x_max, y_max) with min <= max, got {self.box}")
        if self.frame < 0 or self.ident < 1:
            raise ValueError(f"frame >= 0 and ident >= 1, got frame {self.frame}, ident {self.ident}")
        check_url(self.url)


@dataclass(frozen=True)
class Annotation:
    """One object over one stretch of frames ``start..end`` (inclusive), with its link."""

    ident: int
    object_name: str
    object_id: int
    start: int
    end: int
    url: str = ""
    description: str = ""
    boxes: tuple[BoundingBox, ...] = ()

    def __post_init__(self) -> None:
        if not 0 <= self.start <= self.end:
            raise ValueError(f"frames: 0 <= start <= end, got {self.start}..{self.end}")
        outside = [b.frame for b in self.boxes if not self.start <= b.frame <= self.end]
        if outside:
            raise ValueError(f"annotation {self.ident} ({self.object_name}) spans frames {self.start}..{self.end} "
                             f"but has a box in frame {outside[0]}")
        check_url(self.url)


@dataclass(frozen=True)
class Scene:
    ident: int
    start: int
    end: int
    description: str = ""
    annotations: tuple[Annotation, ...] = ()

    @property
    def duration(self) -> int:
        return self.end - self.start + 1


@dataclass(frozen=True)
class CdpHeader:
    """A render's whole header.  Sizes are ``(width, height)`` pixels, views ``(Nx, Ny)`` and the
    centre view ``(l, k)`` (row, column of the camera bank), as the XML writes them."""

    uuid: str
    content_id: str
    name: str
    views: tuple[int, int]
    centre_view: tuple[int, int]
    view_size: tuple[int, int]
    h3d_size: tuple[int, int] | None = None
    info: str = ""
    scenes: tuple[Scene, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        if not self.scenes:
            raise ValueError("scenes: a header has at least one scene")


def _schema():
    from lxml import etree

    with resources.files(__package__).joinpath(SCHEMA).open("rb") as fh:
        return etree.XMLSchema(etree.parse(fh))


def _pair(values: tuple[int, int]) -> str:
    return f"{values[0]} {values[1]}"


def to_xml(header: CdpHeader) -> bytes:
    """The header as UTF-8 XML (valid against the schema; checked before it is returned)."""
    from lxml import etree

    root = etree.Element("CDP", nsmap={"xsi": _XSI})
    root.set(_SCHEMA_LOCATION, SCHEMA)
    etree.SubElement(root, "UUID").text = header.uuid
    content = etree.SubElement(root, "Content")
    info = etree.SubElement(content, "ContentInfo", SceneCounter=str(len(header.scenes)), id=header.content_id,
                            name=header.name, views=_pair(header.views), centreView=_pair(header.centre_view),
                            viewSize=_pair(header.view_size))
    if header.h3d_size is not None:
        info.set("h3dSize", _pair(header.h3d_size))
    info.text = header.info
    for scene in header.scenes:
        s = etree.SubElement(content, "Scene", id=str(scene.ident), startFrame=str(scene.start),
                             endFrame=str(scene.end), wholeDuration=str(scene.duration), SceneDesc=scene.description)
        for a in scene.annotations:
            ann = etree.SubElement(s, "Annotation", id=str(a.ident), object=a.object_name, objectId=str(a.object_id))
            desc = etree.SubElement(ann, "OperatorDesc", startFrame=str(a.start), endFrame=str(a.end),
                                    frameFormat="png", description=a.description, url=a.url)
            op = etree.SubElement(desc, "Operator", ID="0", Name="povh3d", status="ground truth", role="renderer",
                                  GUI="", OperatorDesc="object masks of every ray's first hit")
            for b in a.boxes:
                box = etree.SubElement(op, "BoundingBox", ID=str(b.ident), frame=str(b.frame), space=b.space,
                                       BoundingBoxDesc=b.description, URL=b.url)
                etree.SubElement(box, "Min", X=str(b.box[0]), Y=str(b.box[1]))
                etree.SubElement(box, "Max", X=str(b.box[2]), Y=str(b.box[3]))
                if b.results:
                    sr = etree.SubElement(box, "SearchResult", SearchResultCounter=str(len(b.results)))
                    for r in b.results:
                        etree.SubElement(sr, "SearchResultItem", contentType=r.content_type,
                                         relevance=repr(float(r.relevance)), ItemDesc=r.description, url=r.url)
    _schema().assertValid(root)
    return etree.tostring(root, xml_declaration=True, encoding="utf-8", pretty_print=True)


def from_xml(data: bytes, name: str = "the header") -> CdpHeader:
    """Read a header; damaged XML, an unknown element or attribute, or a box outside its
    annotation is one ``InputError`` naming it."""
    from lxml import etree

    if len(data) > MAX_HEADER_BYTES:
        raise InputError(f"{name} is {len(data) / 2**20:.3g} MB, over the {MAX_HEADER_BYTES >> 20} MB a 3DCDP header "
                         "may take; write it again with 'povh3d annotate'")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, remove_blank_text=True)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        raise InputError(f"{name} is not well-formed XML ({exc}); write it again with 'povh3d annotate'") from None
    if root.getroottree().docinfo.doctype:  # entities could pull other files in: none are needed
        raise InputError(f"{name} has a DOCTYPE; a 3DCDP header takes none (remove it)")
    if root.tag != "CDP":
        raise InputError(f"{name} is not a 3DCDP header: its root is <{root.tag}>, not <CDP>")
    schema = _schema()
    if not schema.validate(root):
        err = schema.error_log.last_error
        raise InputError(f"{name} line {err.line}: {err.message}; a 3DCDP header follows {SCHEMA}") from None
    try:
        return _header(root)
    except ValueError as exc:
        raise InputError(f"{name}: {raw_message(exc)}") from None


def _ints(text: str, what: str) -> tuple[int, int]:
    parts = text.split()
    if len(parts) != 2 or not all(p.isdigit() for p in parts):
        raise ValueError(f"{what} takes two whole numbers 'A B', got {text!r}")
    return int(parts[0]), int(parts[1])


def _header(root) -> CdpHeader:
    info = root.find("Content/ContentInfo")
    for sr in root.iter("SearchResult"):
        if int(sr.get("SearchResultCounter")) != len(sr):
            raise ValueError(f"line {sr.sourceline}: SearchResultCounter says {sr.get('SearchResultCounter')} "
                             f"but {len(sr)} SearchResultItem follow")
    scenes = []
    for s in root.iterfind("Content/Scene"):
        annotations = []
        for a in s.iterfind("Annotation"):
            desc = a.find("OperatorDesc")
            boxes = tuple(
                BoundingBox(int(b.get("ID")), int(b.get("frame")), b.get("space"),
                            (int(b.find("Min").get("X")), int(b.find("Min").get("Y")),
                             int(b.find("Max").get("X")), int(b.find("Max").get("Y"))),
                            b.get("BoundingBoxDesc"), b.get("URL"),
                            tuple(SearchResultItem(r.get("url"), r.get("contentType"), float(r.get("relevance")),
                                                   r.get("ItemDesc")) for r in b.iterfind("SearchResult/SearchResultItem")))
                for b in desc.iterfind("Operator/BoundingBox"))
            annotations.append(Annotation(int(a.get("id")), a.get("object"), int(a.get("objectId")),
                                          int(desc.get("startFrame")), int(desc.get("endFrame")),
                                          desc.get("url"), desc.get("description"), boxes))
        scene = Scene(int(s.get("id")), int(s.get("startFrame")), int(s.get("endFrame")), s.get("SceneDesc"),
                      tuple(annotations))
        if int(s.get("wholeDuration")) != scene.duration:
            raise ValueError(f"scene {scene.ident} spans frames {scene.start}..{scene.end} but says "
                             f"wholeDuration {s.get('wholeDuration')}")
        scenes.append(scene)
    if int(info.get("SceneCounter")) != len(scenes):
        raise ValueError(f"ContentInfo counts {info.get('SceneCounter')} scenes but the header holds {len(scenes)}")
    h3d = info.get("h3dSize")
    return CdpHeader(root.findtext("UUID") or "", info.get("id"), info.get("name"), _ints(info.get("views"), "views"),
                     _ints(info.get("centreView"), "centreView"), _ints(info.get("viewSize"), "viewSize"),
                     _ints(h3d, "h3dSize") if h3d is not None else None, info.text or "", tuple(scenes))
