"""Which POV-Ray features a scene uses, and so which global settings it needs.

povh3d adds to the script header only what the scene needs: ``assumed_gamma``
when the scene sets none, and a quality level's global settings only where the
scene has something they act on (``max_trace_level`` only with reflection or
refraction, radiosity settings only with radiosity, photon settings only with
photons).  A quality's radiosity block in a scene without radiosity would turn
radiosity on; its pretrace alone costs more than the render (``make bench``).

Detection reads the scene, every file it includes and the POV-Ray include
files it names (``textures.inc`` ...), without comments, and looks for the
keywords.  It errs on the side of "used": a keyword in a declared texture the
scene never applies still counts.  A scene that builds keywords at parse time
(``#read``, ``Parse_String``) can hide them; the crop's own check (``crop``)
does not rely on this module for correctness.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

#: Keywords that show a feature is used, one regex per feature; tests loop over it.
FEATURE_PATTERNS: dict[str, str] = {
    "radiosity": r"\bradiosity\b",
    "photons": r"\bphotons\b",
    "media": r"\bmedia\b",
    "area_light": r"\barea_light\b",
    "reflection": r"\b(?:reflection|reflection_exponent)\b",
    "refraction": r"\b(?:ior|refraction|dispersion|transmit|filter|rgbt|rgbf|rgbft)\b",
    "fog": r"\bfog\b",
    "sky_sphere": r"\bsky_sphere\b",
    "rainbow": r"\brainbow\b",
}
_COMPILED = {name: re.compile(p) for name, p in FEATURE_PATTERNS.items()}

#: Which features a global setting acts on; a setting is written only when one is used.
SETTING_NEEDS: dict[str, tuple[str, ...]] = {
    "max_trace_level": ("reflection", "refraction"),
    "adc_bailout": ("reflection", "refraction", "media"),
    "radiosity": ("radiosity",),
    "photons": ("photons",),
}


@dataclass(frozen=True)
class Features:
    """The features found in a scene's text (see ``FEATURE_PATTERNS``)."""

    used: frozenset[str]

    def __contains__(self, name: str) -> bool:
        return name in self.used

    @property
    def background_is_constant(self) -> bool:
        """A ray that meets nothing shows the ``background`` colour, the same for every ray.

        Not so with fog (ground fog and turbulent fog vary with the direction),
        atmospheric media, a sky_sphere or a rainbow.  Media inside objects cannot be told apart from
        atmospheric media by keywords, so any media counts.
        """
        return not (self.used & {"fog", "media", "sky_sphere", "rainbow"})

    def describe(self) -> list[str]:
        return sorted(self.used)


COMMENTS = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)


def strip_comments(text: str) -> str:
    """POV-Ray source without its ``//`` and ``/* */`` comments."""
    return COMMENTS.sub("", text)


def features_of_text(texts: Iterable[str]) -> Features:
    """Features used in POV-Ray source texts (comments are ignored)."""
    used: set[str] = set()
    for text in texts:
        text = strip_comments(text)
        used.update(name for name, rx in _COMPILED.items() if rx.search(text))
    return Features(frozenset(used))


def needed_settings(features: Features, requested: Mapping[str, Any]) -> dict[str, Any]:
    """The requested global settings that act on something the scene uses.

    Parameters
    ----------
    features : Features
    requested : mapping
        ``global_settings`` keyword -> POV-Ray text of its value, e.g.
        ``{"max_trace_level": "10", "radiosity": "{ count 200 }"}``.

    Returns
    -------
    dict, in the order requested; a keyword unknown to ``SETTING_NEEDS`` is kept
    (better a setting too many than a wrong image).
    """
    return {key: value for key, value in requested.items()
            if key not in SETTING_NEEDS or any(f in features for f in SETTING_NEEDS[key])}
