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

#: Keywords that show a feature is used; tests loop over it.
FEATURE_WORDS: dict[str, frozenset[str]] = {name: frozenset(words) for name, words in {
    "radiosity": ("radiosity",),
    "photons": ("photons",),
    "media": ("media",),
    "area_light": ("area_light",),
    "reflection": ("reflection", "reflection_exponent"),
    "refraction": ("ior", "refraction", "dispersion", "transmit", "filter", "rgbt", "rgbf", "rgbft"),
    "fog": ("fog",),
    # an interior's index of refraction (refraction, fresnel reflection): worked out from the solids a
    # ray is in, unlike the refraction words, which colors.inc's rgbf colours name in nearly every scene
    "ior": ("ior",),
    "sky_sphere": ("sky_sphere",),
    "rainbow": ("rainbow",),
    "subsurface": ("subsurface",),
}.items()}
# Words, not regexes over the text: a scene's text is read once into its set of words, so a
# 100 MB mesh include costs one pass, not one per keyword (numbers hold no words).
_WORD = re.compile(r"[A-Za-z_]\w*")

#: Which features a global setting acts on; a setting is written only when one is used.
SETTING_NEEDS: dict[str, tuple[str, ...]] = {
    "max_trace_level": ("reflection", "refraction"),
    "adc_bailout": ("reflection", "refraction", "media"),
    "radiosity": ("radiosity",),
    "photons": ("photons",),
    "subsurface": ("subsurface",),
}


@dataclass(frozen=True)
class Features:
    """The features found in a scene's text (see ``FEATURE_WORDS``)."""

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


# A string literal first: POV-Ray reads ``"a//b"`` as a string, not as the start of a comment, so
# the comment marks inside a string must not hide what follows it on the line (``#include``).
_STRING_OR_COMMENT = re.compile(r'"(?:\\.|[^"\\\n])*"|//[^\n]*|/\*.*?\*/', re.S)


def strip_comments(text: str) -> str:
    """POV-Ray source without its ``//`` and ``/* */`` comments; string literals are kept whole.

    A comment becomes one space (``a/**/b`` is two words to POV-Ray, as here).
    """
    return _STRING_OR_COMMENT.sub(lambda m: m.group() if m.group().startswith('"') else " ", text)


def words_of(text: str) -> frozenset[str]:
    """The identifiers and keywords of POV-Ray source (comments left out)."""
    return frozenset(_WORD.findall(strip_comments(text)))


def features_of_words(words: Iterable[frozenset[str]]) -> Features:
    """Features used in POV-Ray sources, each given as its ``words_of``."""
    used: set[str] = set()
    for w in words:
        used.update(name for name, keys in FEATURE_WORDS.items() if keys & w)
    return Features(frozenset(used))


def features_of_text(texts: Iterable[str]) -> Features:
    """Features used in POV-Ray source texts (comments are ignored)."""
    return features_of_words(words_of(t) for t in texts)


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
